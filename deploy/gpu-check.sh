#!/usr/bin/env bash
# Check a new GPU node end to end: cavesim doctor, the test suite, the bench (1M, 10M and
# the largest capacity), the frame logs in tests/data/logs replayed bit for bit, and the
# 4-wall brownout demo. Prints a summary of at most 30 lines; writes out/gpu-check/.
# Usage: deploy/gpu-check.sh [--out DIR] [--tests full|fast|none] [--quick]
# Python: .venv's if deploy/setup.sh made one; else python3 where it already imports
# cavesim, moderngl, zenoh and pytest (a node without network); else deploy/setup.sh --test.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -x .venv/bin/python ] && .venv/bin/python -c "import pytest" 2>/dev/null; then
    python=.venv/bin/python
elif python3 -c "import cavesim, moderngl, zenoh, pytest" 2>/dev/null; then
    python=python3
else
    deploy/setup.sh --test
    python=.venv/bin/python
fi
exec "$python" -m nodes.gpu_check "$@"
