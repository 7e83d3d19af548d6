#!/usr/bin/env bash
# Network solves spread over MPI ranks (issue 24 item 2): BoomerAMG-PCG to 1e-8 on 1 rank and on
# 2 ranks (mpirun -np 2 bench_electric --spread), 1e6 and 4e6 nodes, bonded and packing families,
# one OpenMP thread per rank. Every solve is scored against the same one-rank AMG reference at
# 1e-13 (G_rel_err, V_max_err). Writes benchmarks/electric_solvers/spread.csv (the rows of both
# runs, method amg = 1 rank, amg_spread2 = 2 ranks).
#   benchmarks/electric_solvers/run_spread.sh [build dir]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
build="${1:-$here/../../build}"
bench="$build/benchmarks/electric_solvers/bench_electric"
tmp="$(mktemp -d)"
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE
for n in 1000000 4000000; do
  for fam in bonded packing; do
    "$bench" --sizes $n --families $fam --solvers amg --tolerances 1e-8 --csv "$tmp/one_${fam}_$n.csv"
    mpirun --allow-run-as-root --oversubscribe -np 2 "$bench" --spread --sizes $n --families $fam --solvers amg \
      --tolerances 1e-8 --csv "$tmp/two_${fam}_$n.csv"
  done
done
{
  head -1 "$tmp/one_bonded_1000000.csv" | sed 's/$/,commit,load_average_at_end/'
  for f in "$tmp"/one_*.csv "$tmp"/two_*.csv; do tail -n +2 "$f" | sed "s/\$/,$(git -C "$here" rev-parse --short HEAD),$(cut -d' ' -f1 /proc/loadavg)/"; done
} > "$here/spread.csv.tmp"
mv "$here/spread.csv.tmp" "$here/spread.csv"
rm -rf "$tmp"
cat "$here/spread.csv"
