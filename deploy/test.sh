#!/usr/bin/env bash
# Set up (if needed) with the test dependencies, lint, and run the whole test suite
# (slow tests included) on every core (pytest-xdist), failing any test whose outside tool
# is missing rather than skipping it. Extra arguments go to pytest.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/deploy/setup.sh" --test
cd "$root"
.venv/bin/ruff check cavesim nodes tests
exec .venv/bin/python -m pytest -n auto --require-tools "$@"
