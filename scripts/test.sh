#!/usr/bin/env bash
# The whole test suite: install, build, run every test; then the same suite
# again under AddressSanitizer + UndefinedBehaviorSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/setup.sh build
# The dependency rule (LAYERS, docs/architecture.md): names the file and
# line of an include against it. ctest runs it too, as layer_rule.
python3 scripts/check_layers.py
# The length rule (LENGTHS_ALLOWED, docs/architecture.md): names the file,
# line and length of a unit over it. ctest runs it too, as length_rule.
python3 scripts/check_lengths.py
# A failed run ends with each failed test's last lines (ctest_recap.py), so
# that the log's tail says why and not only which.
run_ctest() {
  local dir=$1
  shift
  if ! "$@" ctest --test-dir "$dir" --output-on-failure -j "$(nproc)"; then
    python3 scripts/ctest_recap.py "$dir"
    return 1
  fi
}
echo "==> tests (RelWithDebInfo)"
run_ctest build env

# Built with clang: GCC's UndefinedBehaviorSanitizer doubles the compile time
# of a file (a test file: 22 s under GCC, 15 s under clang, 12 s without the
# sanitizers; BENCHMARKS.md, "CI time"), and a second compiler's warnings
# and checks come with it.
scripts/setup.sh build-asan -DHAPTICLAB_SANITIZE=ON -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++
echo "==> tests (address + undefined behaviour sanitizers)"
run_ctest build-asan env ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
