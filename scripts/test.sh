#!/usr/bin/env bash
# The whole test suite: install, build, run every test; then the same suite
# again under AddressSanitizer + UndefinedBehaviorSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/setup.sh build
echo "==> tests (RelWithDebInfo)"
ctest --test-dir build --output-on-failure -j "$(nproc)"

scripts/setup.sh build-asan -DHAPTICLAB_SANITIZE=ON
echo "==> tests (address + undefined behaviour sanitizers)"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan --output-on-failure -j "$(nproc)"
