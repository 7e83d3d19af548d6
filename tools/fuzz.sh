#!/usr/bin/env bash
# Reproduces the large fuzz campaigns of issue 9 (part 4) with tests/fuzz/fuzz_driver.cpp:
#   1e5 mutated scenario files against the loader, 1e4 mutated (re-sealed) checkpoints against the
#   restart reader; every case in a forked child with a time limit (see the driver's header).
# Usage: tools/fuzz.sh [BUILD_DIR=build] [OUT_DIR=benchmarks/fuzz] [LOADER_CASES=100000] [CHECKPOINT_CASES=10000]
#   FUZZ_CAMPAIGNS="checkpoint loader" (default: both, in that order), FUZZ_SEED=1, FUZZ_BIN (default BUILD_DIR/tests/sparkdem_fuzz),
#   FUZZ_MAX_SECONDS (loader: stop and report after this wall time; 0 = run every case)
# Writes OUT_DIR/loader.json and OUT_DIR/checkpoint.json (counts per outcome class, per seed,
# every bug case with its recipe) and OUT_DIR/fuzz_summary.csv (one line per campaign).
# Single-threaded and niced: the machine is shared.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$here/build}"
out="${2:-$here/benchmarks/fuzz}"
loader_cases="${3:-100000}"
checkpoint_cases="${4:-10000}"
seed="${FUZZ_SEED:-1}"
mkdir -p "$out"
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE
# Scratch on tmpfs when there is one (restarts write and fsync their outputs).
scratch="${FUZZ_SCRATCH:-$( [ -d /dev/shm ] && echo /dev/shm || echo "${TMPDIR:-/tmp}")}/sparkdem_fuzz_$$"
trap 'rm -rf "$scratch"' EXIT
mkdir -p "$scratch"
bin="${FUZZ_BIN:-$build/tests/sparkdem_fuzz}"
# The driver is not in the default build target (tests/CMakeLists.txt).
[ -n "${FUZZ_BIN:-}" ] || cmake --build "$build" --target sparkdem_fuzz
campaigns="${FUZZ_CAMPAIGNS:-checkpoint loader}"
status=0
if [[ " $campaigns " == *" checkpoint "* ]]; then
nice -n 10 "$bin" checkpoint --cases "$checkpoint_cases" --seed "$seed" \
  --work "$scratch/checkpoint" --out "$out/checkpoint.json" --time-limit 20 --source "$here" || status=1
fi
if [[ " $campaigns " == *" loader "* ]]; then
nice -n 10 "$bin" loader --cases "$loader_cases" --seed "$seed" \
  --work "$scratch/loader" --out "$out/loader.json" --time-limit 10 --source "$here" \
  --max-seconds "${FUZZ_MAX_SECONDS:-0}" || status=1
fi
# Bug inputs are kept next to the reports.
for m in checkpoint loader; do
  if [ -d "$scratch/$m/bugs" ] && [ -n "$(ls -A "$scratch/$m/bugs")" ]; then
    mkdir -p "$out/bugs_$m" && cp "$scratch/$m/bugs/"* "$out/bugs_$m/"
  fi
done
/usr/bin/python3 - "$out" <<'PY'
import json, sys, os
out = sys.argv[1]
rows = ["campaign,cases,wall_time_s,bugs,outcomes"]
for m in ("loader", "checkpoint"):
    p = os.path.join(out, m + ".json")
    if not os.path.exists(p):
        continue
    j = json.load(open(p))
    outcomes = ";".join(f"{k}={v}" for k, v in sorted(j["outcomes"].items()))
    rows.append(f'{m},{j["cases"]},{j["wall_time_s"]:.1f},{j["bug_count"]},"{outcomes}"')
open(os.path.join(out, "fuzz_summary.csv"), "w").write("\n".join(rows) + "\n")
print("\n".join(rows))
PY
exit $status
