#!/usr/bin/env bash
# The main job on the bundled defaults: build the targets, run the test case collection,
# check version consistency against the reference target, write JUnit XML.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh main
harness build
harness run -j "${HARNESS_JOBS:-2}"
harness check --junit "${HARNESS_JUNIT:-.harness/junit.xml}"
