#!/usr/bin/env bash
# The whole test suite: install, build, run every test; then the same suite
# again under AddressSanitizer + UndefinedBehaviorSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/setup.sh build

# The sanitizer build, built with clang: GCC's UndefinedBehaviorSanitizer
# doubles the compile time of a file (a test file: 22 s under GCC, 15 s
# under clang, 12 s without the sanitizers; BENCHMARKS.md, "CI time"), and a
# second compiler's warnings and checks come with it. It starts now, beside
# the release tests, at the lowest CPU priority: they leave about a sixth of
# the cores idle (tests that wait on processes, sockets, a browser), and a
# test that wants a core still gets it first. Its output follows theirs.
asan_log=$(mktemp)
nice -n 19 setsid scripts/setup.sh build-asan -DHAPTICLAB_SANITIZE=ON -DCMAKE_C_COMPILER=clang \
  -DCMAKE_CXX_COMPILER=clang++ >"$asan_log" 2>&1 &
asan_build=$!
# A failing release test (or an interrupt) stops the build too.
trap 'kill -- -"$asan_build" 2>/dev/null || true; rm -f "$asan_log"' EXIT

echo "==> tests (RelWithDebInfo)"
ctest --test-dir build --output-on-failure -j "$(nproc)"

asan_status=0
wait "$asan_build" || asan_status=$?
cat "$asan_log"
if ((asan_status != 0)); then
  echo "==> the sanitizer build failed (exit $asan_status)"
  exit "$asan_status"
fi
echo "==> tests (address + undefined behaviour sanitizers)"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan --output-on-failure -j "$(nproc)"
