#!/usr/bin/env bash
# Install torchshm and its test tools into ./.venv (created if missing).
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
    .venv/bin/python -m pip install -q -e ".[test]"
    echo "$want" > "$stamp"
fi
