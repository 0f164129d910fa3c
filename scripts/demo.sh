#!/usr/bin/env bash
# The main job: install, build, and run the demo on the embedded defaults.
#   scripts/demo.sh [demo options...]    (e.g. --out DIR, --quick)
set -euo pipefail
cd "$(dirname "$0")/.."
# Only what the demo runs: the hapticlab tool (the test suite is most of a
# full build; scripts/test.sh builds it in the same directory).
HAPTICLAB_TARGETS=hapticlab_cli scripts/setup.sh build
build/app/hapticlab demo "$@"
