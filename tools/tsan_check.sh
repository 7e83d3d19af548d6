#!/usr/bin/env bash
# ThreadSanitizer check: builds sparkdem with -DSPARKDEM_TSAN=ON into build-tsan and runs a small
# frictional pour (tests/scenario/data/restart_pour.json: 288 spheres, friction 0.5, walls,
# 3000 steps) with 2 OpenMP threads. Exit status 0 when TSan reports no race, 1 otherwise.
#
# usage: tools/tsan_check.sh [extra TSAN_OPTIONS]
#   BUILD=dir        build directory (default: <repo>/build-tsan)
#   SCENE=file.json  scenario to run (default: the pour above)
#   JOBS=n           ninja jobs (default 1)
#
# OpenMP runtime: GCC's libgomp is not built with TSan, so TSan cannot see its barriers and
# reports every hand-over between a parallel region and the serial code as a race (false
# positives; TSAN_OPTIONS=ignore_noninstrumented_modules=1 does not remove them because the racing
# accesses themselves are in instrumented code). The script therefore builds with clang and
# LLVM's libomp and loads the Archer OMPT tool (libarcher.so), which tells TSan about OpenMP
# synchronisation. CXX=g++ CC=gcc selects the libgomp build anyway (expect false positives).
# Extra arguments are appended to TSAN_OPTIONS.
set -euo pipefail

SRC="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${BUILD:-$SRC/build-tsan}"
SCENE="${SCENE:-$SRC/tests/scenario/data/restart_pour.json}"
JOBS="${JOBS:-1}"
export CC="${CC:-clang}" CXX="${CXX:-clang++}"

mkdir -p "$BUILD"
# A build directory configured with another compiler must be reconfigured from scratch.
if [[ -f "$BUILD/CMakeCache.txt" ]] &&
   ! grep -q "^CMAKE_CXX_COMPILER:[A-Z]*=\(.*/\)\?$(basename "$CXX")\$" "$BUILD/CMakeCache.txt"; then
  rm -rf "$BUILD/CMakeCache.txt" "$BUILD/CMakeFiles"
fi
cmake -S "$SRC" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSPARKDEM_TSAN=ON \
  -DSPARKDEM_BUILD_TESTS=OFF -DSPARKDEM_BUILD_BENCHMARKS=OFF > "$BUILD/tsan_cmake.log" 2>&1 ||
  { cat "$BUILD/tsan_cmake.log"; exit 2; }
ninja -C "$BUILD" -j "$JOBS" sparkdem

OUT="$(mktemp -d "${TMPDIR:-/tmp}/sparkdem_tsan.XXXXXX")"
trap 'rm -rf "$OUT"' EXIT
LOG="$OUT/tsan"
export TSAN_OPTIONS="ignore_noninstrumented_modules=1 halt_on_error=0 second_deadlock_stack=1 log_path=$LOG ${*:-}"
export OMP_NUM_THREADS=2 OMP_WAIT_POLICY=PASSIVE
if [[ "$("$CXX" --version)" == *clang* ]]; then
  ARCHER="$(dirname "$(readlink -f "$(command -v "$CXX")")")/../lib/libarcher.so"
  if [[ -f "$ARCHER" ]]; then
    export OMP_TOOL_LIBRARIES="$ARCHER" ARCHER_OPTIONS="${ARCHER_OPTIONS:-verbose=1}"
  else
    echo "warning: $ARCHER not found; OpenMP synchronisation is invisible to TSan (false positives likely)"
  fi
fi

echo "running: sparkdem run $SCENE --threads 2"
echo "  CXX=$CXX TSAN_OPTIONS=$TSAN_OPTIONS OMP_TOOL_LIBRARIES=${OMP_TOOL_LIBRARIES:-}"
set +e
start=$(date +%s)
"$BUILD/sparkdem" run "$SCENE" -o "$OUT/run" --threads 2 --quiet
rc=$?
set -e
echo "sparkdem exit code $rc after $(( $(date +%s) - start )) s"

reports=0
rm -f "$BUILD/tsan_last.log"
if compgen -G "$LOG.*" > /dev/null; then
  reports=$(cat "$LOG".* | grep -c "WARNING: ThreadSanitizer" || true)
  cat "$LOG".* > "$BUILD/tsan_last.log"
  head -200 "$BUILD/tsan_last.log"
  echo "(full TSan log: $BUILD/tsan_last.log)"
fi
echo "ThreadSanitizer reports: $reports"
if [[ $rc -ne 0 && $rc -ne 66 ]]; then echo "the run itself failed"; exit 1; fi
[[ $reports -eq 0 ]]
