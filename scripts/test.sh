#!/usr/bin/env bash
# The test suite: installs what it needs, then runs pytest (extra arguments are passed on).
# Two worker processes (pytest-xdist), each taking whole test modules: most tests wait on the programs they
# start, so two workers halve the default run on two cores. HARNESS_TEST_WORKERS=0 (or -n 0) runs the tests in
# one process; -n N on the command line wins over the variable.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
exec python3 -m pytest -n "${HARNESS_TEST_WORKERS:-2}" --dist loadfile "$@"
