#!/bin/sh
# Seed 002 percolation measurements (cpc_fillers + contact_percolation), one thread:
#   uniform (lambda = 0) at L = 60, 70, 80 R, 10 seeds per phi, plus 30 more seeds at L = 70 R
#   near and above phi_c (the exponent t); segregated at lambda = 35 R and lambda = 70 R (= 35 D)
#   at L = 70 R, and lambda = 70 R at L = 60 and 80 R, 8 seeds per phi.
# Writes results_points.csv, results_fits.csv, results.png here (tools/plot_cpc.py analyse).
# Run time about 3 minutes on one core; the sweep item directories (about 16 MB each at
# L = 70 R) are deleted after each run. Usage: benchmarks/cpc_percolation/run_cpc.sh [BUILD] [SCRATCH]
set -e
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
build=${1:-$root/build}
work=${2:-/tmp/cpc_percolation}
py=${PYTHON:-python3}
mkdir -p "$work"
run() {  # name, config arguments...
  name=$1; shift
  "$py" "$root/tools/plot_cpc.py" config --out "$work/$name.json" --name "$name" "$@"
  start=$(date +%s.%N)
  OMP_NUM_THREADS=1 "$build/sparkdem" run "$work/$name.json" -o "$work/$name" --threads 1 --quiet
  echo "$name: $(echo "$(date +%s.%N) - $start" | bc) s"
  rm -rf "$work/$name"/sweep_*/[0-9]*
}
run u60 --box 60 --seeds 10 --phis 0.18,0.20,0.21,0.22,0.23,0.24,0.25,0.26,0.28,0.31,0.35
run u70 --box 70 --seeds 10 --phis 0.16,0.18,0.20,0.21,0.22,0.23,0.24,0.25,0.26,0.28,0.31,0.35
run u80 --box 80 --seeds 10 --phis 0.18,0.20,0.21,0.22,0.23,0.24,0.25,0.26,0.28,0.31,0.35
run s70R --box 70 --lam 35 --seeds 8 --phis 0.02,0.03,0.035,0.04,0.045,0.05,0.06,0.08,0.10,0.13,0.16,0.20
for L in 60 70 80; do
  run s${L}D --box $L --lam 70 --seeds 8 --phis 0.02,0.03,0.04,0.05,0.06,0.08,0.10,0.13
done
# 30 more seeds (101-130) at L = 70 R around and above phi_c, for t.
"$py" "$root/tools/plot_cpc.py" config --out "$work/u70b.json" --name u70b --box 70 --seeds 30 \
  --phis 0.22,0.23,0.235,0.24,0.25,0.26,0.27,0.29,0.32,0.36
"$py" - "$work/u70b.json" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
for st in j["stages"]:
    st["sweep"]["seeds"] = list(range(101, 131))
json.dump(j, open(sys.argv[1], "w"))
PY
start=$(date +%s.%N)
OMP_NUM_THREADS=1 "$build/sparkdem" run "$work/u70b.json" -o "$work/u70b" --threads 1 --quiet
echo "u70b: $(echo "$(date +%s.%N) - $start" | bc) s"
rm -rf "$work/u70b"/sweep_*/[0-9]*
cd "$work"
"$py" "$root/tools/plot_cpc.py" analyse u60 u70 u70b u80 s70R s60D s70D s80D --prefix "$here/results"
