#!/usr/bin/env bash
# Install torchshm, its test tools and the examples' FE programs into ./.venv (created if
# missing): the `fe` extra (OpenSeesPy) and, when `ccx` is missing, CalculiX from the system's
# packages (apt-get install calculix-ccx; only as root with apt-get, else a message says how).
#
# torch is pinned to 2.13.0 before anything else, and held there by a constraint, so that no
# CUDA build is ever pulled; every other requirement admits the installed torch. The installer
# is uv where it installs (much faster), else pip. The step is skipped when pyproject.toml has
# not changed since the last successful install.
set -euo pipefail
cd "$(dirname "$0")/.."
py="${PYTHON:-python3}"
[ -x .venv/bin/python ] || "$py" -m venv .venv
stamp=".venv/.torchshm-installed"
want="$(cat pyproject.toml scripts/install.sh | sha256sum | cut -d' ' -f1)"
# uv (PyPI's `uv`, a faster installer: 109 s against 181 s for this step, 2026-11-30) where it
# can be had; pip otherwise, or where uv fails. Both are held to torch 2.13.0 by a constraint.
pin="$(mktemp)"; trap 'rm -f "$pin"' EXIT; echo "torch==2.13.0" > "$pin"
install_pip() {
    .venv/bin/python -m pip install -q "torch==2.13.0" &&
        .venv/bin/python -m pip install -q -c "$pin" -e ".[test,fe]"
}
install_uv() {
    .venv/bin/python -m pip install -q uv >/dev/null 2>&1 && [ -x .venv/bin/uv ] || return 1
    local uv=(.venv/bin/uv pip install -q --compile-bytecode --python .venv/bin/python -c "$pin")
    # the CPU build of torch: a local wheel where pip's find-links has one (uv does not read
    # pip's configuration), else through pip, which does
    local links tag wheel=""
    links="${PIP_FIND_LINKS:-$(.venv/bin/python -m pip config get global.find-links 2>/dev/null || true)}"
    tag="$(.venv/bin/python -c 'import sys; print("cp%d%d" % sys.version_info[:2])')"
    for dir in $links; do
        wheel="$(ls "$dir"/torch-2.13.0*-"$tag"-*"$(uname -m)".whl 2>/dev/null | head -n 1 || true)"
        [ -n "$wheel" ] && break
    done
    if [ -n "$wheel" ]; then "${uv[@]}" "$wheel" || return 1
    else .venv/bin/python -m pip install -q "torch==2.13.0" || return 1; fi
    "${uv[@]}" -e ".[test,fe]"
}
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
    install_uv || { echo "uv could not install torchshm's requirements: pip instead"; install_pip || exit 1; }
    echo "$want" > "$stamp"
fi
# Byte-code for torchshm's own (editable) sources, the benchmark cases, examples and studies: where
# PYTHONDONTWRITEBYTECODE is set (as on some CI machines) Python never writes it itself, and
# every process then compiles its imports from source (the main job: 39 s against 22-24 s,
# 14 s of it in `compile`, 2026-12-01). uv is asked for the installed packages' byte-code
# above (--compile-bytecode; it writes none by default); pip writes it by default.
.venv/bin/python -m compileall -q -j 0 torchshm benchmarks examples studies >/dev/null || true
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
