#!/usr/bin/env bash
# Install torchshm, its test tools and the examples' FE programs into ./.venv (created if
# missing): the `fe` extra (OpenSeesPy) and, when `ccx` is missing, CalculiX from the system's
# packages (apt-get install calculix-ccx; only as root with apt-get, else a message says how).
#
# torch is pinned to 2.13.0 before anything else so that no CPU-less (CUDA) build is ever pulled;
# every other requirement admits the installed torch. The step is skipped when pyproject.toml has
# not changed since the last successful install.
set -euo pipefail
cd "$(dirname "$0")/.."
py="${PYTHON:-python3}"
[ -x .venv/bin/python ] || "$py" -m venv .venv
stamp=".venv/.torchshm-installed"
want="$(sha256sum pyproject.toml | cut -d' ' -f1)"
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
    .venv/bin/python -m pip install -q "torch==2.13.0"
    .venv/bin/python -m pip install -q -e ".[test,fe]"
    echo "$want" > "$stamp"
fi
if ! command -v ccx >/dev/null 2>&1; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        echo "installing CalculiX (apt-get install calculix-ccx) for examples/calculix_slab"
        { apt-get update -qq && DEBIAN_FRONTEND=noninteractive \
            apt-get install -y -qq --no-install-recommends calculix-ccx; } >/dev/null 2>&1 \
            || echo "apt-get could not install calculix-ccx: the CalculiX example's tests will fail"
    else
        echo "CalculiX (ccx) is not installed and cannot be here (not root or no apt-get):" \
             "install calculix-ccx; the CalculiX example's tests fail until then"
    fi
fi
