#!/usr/bin/env bash
# The main job: install, build, and run the demo on the embedded defaults.
#   scripts/demo.sh [demo options...]    (e.g. --out DIR, --quick)
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh build
build/app/hapticlab demo "$@"
