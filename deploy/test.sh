#!/usr/bin/env bash
# Set up (if needed) with the test dependencies, lint, and run the whole test suite
# (slow tests included) on every core (pytest-xdist), failing any test whose outside tool
# is missing rather than skipping it. `--fast` runs the fast tier instead: every test but
# those marked slow. Other arguments go to pytest.
#
# Tests are handed out one at a time (--dist loadgroup), the slow ones first
# (tests/conftest.py), so the longest start while every core is free; a module whose tests
# share an expensive fixture keeps them on one worker with an xdist_group mark.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
tier=()
args=()
for arg in "$@"; do
    if [ "$arg" = "--fast" ]; then
        tier=(-m "not slow")
    else
        args+=("$arg")
    fi
done
"$root/deploy/setup.sh" --test
cd "$root"
.venv/bin/ruff check cavesim nodes tests
exec .venv/bin/python -m pytest -n auto --dist loadgroup --require-tools "${tier[@]}" "${args[@]}"
