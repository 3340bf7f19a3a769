#!/usr/bin/env bash
# The test suite: installs what it needs, then runs pytest (extra arguments are passed on).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
exec python3 -m pytest "$@"
