#!/usr/bin/env bash
# Installs HapticLab's build dependencies (Debian 12 packages) if any is
# missing, then configures and builds into a build directory.
#   scripts/setup.sh [BUILD_DIR] [extra cmake arguments...]
# HAPTICLAB_TARGETS="t1 t2" builds only those targets (scripts/demo.sh:
# the command-line tool alone, not the test suite); default: everything.
set -euo pipefail
cd "$(dirname "$0")/.."

build_dir=${1:-build}
shift || true

packages=(g++ make cmake ninja-build pkg-config libeigen3-dev nlohmann-json3-dev libcli11-dev
          libgtest-dev libgmock-dev libsqlite3-dev sqlite3 libboost-math-dev
          libbenchmark-dev gnuplot-nox python3 python3-numpy zlib1g-dev libzstd-dev
          libjs-chart.js)
# Only the test suite needs these (a browser for the report check,
# zstandard for the Python reader of format-3 chunks, crc32c for the numpy
# comparator's CRC-32C: bench/analyze_numpy.py; scipy for the learning-curve
# fits' reference, tests/analysis/learning/scipy_curve_fit.py).
if [[ -z ${HAPTICLAB_TARGETS:-} ]]; then
  packages+=(python3-scipy python3-zstandard python3-crc32c chromium chromium-driver python3-selenium)
  # clang for the sanitizer build (scripts/test.sh), with its sanitizer runtimes
  # (only recommended by clang, so named here).
  packages+=(clang libclang-rt-dev)
  # lld links the test executables about 4x faster than GNU ld (CMakeLists.txt).
  packages+=(lld)
  # A private single-node Slurm cluster for the test of plan power's job
  # array (tests/slurm/): the daemons only; the test configures and starts its own.
  packages+=(slurm-wlm munge)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "==> installing: ${missing[*]}"
  sudo_cmd=()
  if [[ $(id -u) -ne 0 ]]; then sudo_cmd=(sudo); fi
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends \
    "${missing[@]}"
fi

echo "==> building in $build_dir"
# Ninja for a new build folder: it compiles a target's files while the
# libraries it links are still being built, where make waits for them. A
# folder configured before keeps its generator (CMake refuses to switch).
generator=()
if [[ ! -f $build_dir/CMakeCache.txt ]]; then generator=(-G Ninja); fi
cmake -S . -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo "$@" >/dev/null
targets=()
for t in ${HAPTICLAB_TARGETS:-}; do targets+=(--target "$t"); done
cmake --build "$build_dir" -j "$(nproc)" "${targets[@]}"
