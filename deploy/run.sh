#!/usr/bin/env bash
# Set up (if needed) and run a cavesim command, e.g. `deploy/run.sh bench`.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/deploy/setup.sh"
exec "$root/.venv/bin/cavesim" "$@"
