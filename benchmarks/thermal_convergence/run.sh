#!/usr/bin/env bash
# Builds and runs bench_thermal_convergence (one thread, passive OpenMP waits); writes
# results.csv and results.md next to this script. Usage: run.sh [BUILD_DIR] [--quick]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
build="${1:-$here/../../build}"
shift || true
ninja -C "$build" bench_thermal_convergence_exe
OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE "$build/benchmarks/thermal_convergence/bench_thermal_convergence" --out "$here" "$@"
