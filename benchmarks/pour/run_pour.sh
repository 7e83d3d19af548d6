#!/usr/bin/env bash
# Pour benchmark: sparkdem (configs/pour.json) against LAMMPS (the peer input lammps_pour.in) on the
# same machine, in one script. See benchmarks/README.md for what each figure means.
#
#   benchmarks/pour/run_pour.sh [--steps N] [--threads "1 2"] [--sparkdem PATH] [--workdir DIR]
#                               [--csv FILE] [--no-lammps] [--lammps-mpi NP] [--wait-policy active|passive]
#                               [--lammps-matched-wall]
#
#   --steps N        steps of the pour stage for both codes (default 30000, the peer scene);
#                    e.g. --steps 3000 for a quick smoke test
#   --threads LIST   sparkdem thread counts (default "1 2"); each run sets OMP_NUM_THREADS too
#   --sparkdem PATH  sparkdem executable (default: $SPARKDEM_BIN, else <repo>/build/sparkdem)
#   --workdir DIR    where the runs write (default: a new directory under ${TMPDIR:-/tmp})
#   --csv FILE       results table (default benchmarks/pour/results.csv; written to FILE.tmp, then renamed)
#   --no-lammps      skip LAMMPS even if `lmp` is on PATH
#   --lammps-mpi NP  also run LAMMPS with `mpirun -np NP` (1 OpenMP thread per rank) as an extra variant
#   --wait-policy P  export OMP_WAIT_POLICY=P for the sparkdem runs (default: unset, the runtime's
#                    default spin-then-sleep). On a machine shared with other jobs use `passive`:
#                    spinning OpenMP barriers then lose their time slices and a 2-thread run can be
#                    many times slower than 1 thread. The policy is recorded in the `variant` column.
#   --lammps-matched-wall  diagnostic, not part of the benchmark: also run LAMMPS with the wall
#                    modulus E of the three fix wall/gran replaced by E/(1+nu). LAMMPS 29Sep2021's
#                    wall uses E* = E/(2(1-nu)) (as sparkdem's lammps_hertz_tsuji does by default,
#                    lammps2021_wall_modulus = true) where its pairs use E/(2(1-nu^2)); this variant
#                    ("wall-matched") gives the wall the pair E*, as sparkdem with
#                    lammps2021_wall_modulus = false and LAMMPS from 2023 have.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
steps=30000
threads="1 2"
sparkdem="${SPARKDEM_BIN:-$repo/build/sparkdem}"
workdir=""
csv="$here/results.csv"
use_lammps=1
lammps_mpi=0
matched_wall=0
wait_policy=""
dt=1e-5

while [[ $# -gt 0 ]]; do
  case "$1" in
    --steps) steps="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    --sparkdem) sparkdem="$2"; shift 2 ;;
    --workdir) workdir="$2"; shift 2 ;;
    --csv) csv="$2"; shift 2 ;;
    --no-lammps) use_lammps=0; shift ;;
    --lammps-mpi) lammps_mpi="$2"; shift 2 ;;
    --wait-policy) wait_policy="$2"; shift 2 ;;
    --lammps-matched-wall) matched_wall=1; shift ;;
    -h|--help) sed -n '2,24p' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) echo "run_pour.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done

[[ "$steps" =~ ^[0-9]+$ && "$steps" -ge 500 && $((steps % 500)) -eq 0 ]] ||
  { echo "run_pour.sh: --steps must be a positive multiple of 500 (got $steps)" >&2; exit 2; }
[[ -x "$sparkdem" ]] || { echo "run_pour.sh: sparkdem executable not found at $sparkdem (build it, or pass --sparkdem / set SPARKDEM_BIN)" >&2; exit 2; }
/usr/bin/python3 -c "import h5py" 2>/dev/null || { echo "run_pour.sh: needs h5py (Debian: python3-h5py)" >&2; exit 2; }
[[ -z "$wait_policy" || "$wait_policy" == active || "$wait_policy" == passive ]] ||
  { echo "run_pour.sh: --wait-policy must be active or passive" >&2; exit 2; }
if [[ $use_lammps -eq 1 ]] && ! command -v lmp >/dev/null; then
  echo "run_pour.sh: lmp not on PATH: LAMMPS runs skipped"; use_lammps=0
fi

# KE is compared every 5000 steps (the peer's thermo interval); a shorter run uses 3 samples.
if [[ $steps -ge 10000 ]]; then ke_every=5000; else ke_every=$(( (steps / 3 + 499) / 500 * 500 )); fi

[[ -n "$workdir" ]] || workdir="$(mktemp -d "${TMPDIR:-/tmp}/sparkdem_bench_pour.XXXXXX")"
mkdir -p "$workdir"
workdir="$(cd "$workdir" && pwd)"
manifest="$workdir/runs.tsv"
: > "$manifest"
echo "pour benchmark: $steps steps, work directory $workdir"
echo "machine: $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg) (timings are noisy on a shared machine)"

now() { date +%s.%N; }
elapsed() { python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.3f}')" "$1" "$2"; }

# ---------------------------------------------------------------- sparkdem
# The scene is configs/pour.json unchanged except the step count and the output cadence
# (time series every 500 steps, final frame only, no checkpoint).
scene="$workdir/pour_bench.json"
python3 - "$repo/configs/pour.json" "$scene" "$steps" <<'EOF'
import json, sys
c = json.load(open(sys.argv[1]))
dyn = [s for s in c["stages"] if s.get("type", "dynamics") == "dynamics"][-1]
dyn["stop"] = {"steps": int(sys.argv[3])}
dyn["output"] = {"frame_every": 0, "timeseries_every": 500, "checkpoint_every": 0}
json.dump(c, open(sys.argv[2], "w"), indent=1)
EOF
variant="omp${wait_policy:+-$wait_policy}"
for t in $threads; do
  out="$workdir/sparkdem_t$t"
  rm -rf "$out"
  if [[ $t -gt 1 && -z "$wait_policy" ]] &&
     python3 -c "import os,sys; sys.exit(0 if os.getloadavg()[0] > os.cpu_count() - 0.5 else 1)"; then
    echo "warning: load average $(cut -d' ' -f1 /proc/loadavg) on $(nproc) cores: spinning OpenMP barriers will slow the" \
         "$t-thread run badly; consider --wait-policy passive"
  fi
  echo "-- sparkdem, $t thread(s): ${wait_policy:+OMP_WAIT_POLICY=$wait_policy }OMP_NUM_THREADS=$t $sparkdem run $scene -o $out --threads $t --quiet"
  t0=$(now)
  env ${wait_policy:+OMP_WAIT_POLICY=$wait_policy} OMP_NUM_THREADS="$t" \
    "$sparkdem" run "$scene" -o "$out" --threads "$t" --quiet > "$workdir/sparkdem_t$t.log" 2>&1 ||
    { echo "sparkdem failed (exit $?), see $workdir/sparkdem_t$t.log" >&2; tail -20 "$workdir/sparkdem_t$t.log" >&2; exit 1; }
  t1=$(now)
  printf 'sparkdem\t%s\t%s\t1\t%s\t%s\n' "$variant" "$t" "$(elapsed "$t0" "$t1")" "$out" >> "$manifest"
done

# ---------------------------------------------------------------- LAMMPS
if [[ $use_lammps -eq 1 ]]; then
  lin="$here/lammps_pour_dump.in"
  peer="${LAMMPS_PEER_INPUT:-/work/shared/peers/lammps_pour.in}"
  if [[ -f "$peer" ]]; then
    # Like for like: the benchmark input must be the peer input plus tagged output lines only.
    if grep -v 'bench-output' "$lin" | diff -q - "$peer" >/dev/null; then
      echo "LAMMPS input = peer input $peer + output commands only (checked)"
    else
      echo "run_pour.sh: $lin is no longer the peer input plus output commands:" >&2
      grep -v 'bench-output' "$lin" | diff - "$peer" >&2 || true
      exit 1
    fi
  fi
  run_lammps() {  # variant threads ranks input launcher...
    local variant=$1 nthr=$2 ranks=$3 input=$4; shift 4
    local dir="$workdir/lammps_$variant"
    rm -rf "$dir"; mkdir -p "$dir"
    sed -E "s/^run([[:space:]]+)30000/run\\1$steps/" "$input" > "$dir/in.pour"
    grep -qE "^run[[:space:]]+$steps\$" "$dir/in.pour" || { echo "run_pour.sh: could not set the LAMMPS step count" >&2; exit 1; }
    echo "-- LAMMPS $variant: (cd $dir && OMP_NUM_THREADS=$nthr $* -in in.pour -log none)"
    local t0 t1
    t0=$(now)
    (cd "$dir" && OMP_NUM_THREADS=$nthr "$@" -in in.pour -log none > screen.out 2>&1) ||
      { echo "LAMMPS $variant failed, see $dir/screen.out" >&2; tail -20 "$dir/screen.out" >&2; return 1; }
    t1=$(now)
    grep -E "^Loop time" "$dir/screen.out"
    printf 'lammps\t%s\t%s\t%s\t%s\t%s\n' "$variant" "$nthr" "$ranks" "$(elapsed "$t0" "$t1")" "$dir" >> "$manifest"
  }
  run_lammps serial 1 1 "$lin" lmp
  # A threaded LAMMPS needs the OPENMP package (-sf omp -pk omp 2); note that pair granular and
  # fix wall/gran have no /omp variant, so -sf omp would leave them serial anyway.
  if lmp -h | sed -n '/^Installed packages:/,/^List of individual/p' | grep -qw OPENMP; then
    run_lammps omp2 2 1 "$lin" lmp -sf omp -pk omp 2 || echo "LAMMPS -sf omp variant failed: skipped"
  else
    echo "LAMMPS: this build has no OPENMP package: the '-sf omp -pk omp 2' variant is skipped"
  fi
  if [[ $lammps_mpi -gt 1 ]]; then
    if command -v mpirun >/dev/null; then
      mpi=(mpirun -np "$lammps_mpi")
      [[ $(id -u) -eq 0 ]] && mpi+=(--allow-run-as-root)
      run_lammps "mpi$lammps_mpi" 1 "$lammps_mpi" "$lin" "${mpi[@]}" lmp || echo "LAMMPS MPI variant failed: skipped"
    else
      echo "LAMMPS: mpirun not found: the MPI variant is skipped"
    fi
  fi

  if [[ $matched_wall -eq 1 ]]; then
    matched="$workdir/lammps_pour_wall_matched.in"
    python3 - "$lin" "$matched" <<'EOF'
import re, sys
out = []
for line in open(sys.argv[1]):
    m = re.match(r"(fix\s+\S+\s+\S+\s+wall/gran\s+granular\s+hertz/material\s+)(\S+)(\s+)(\S+)(\s+)(\S+)(.*)", line)
    if m:
        e, nu = float(m.group(2)), float(m.group(6))
        line = f"{m.group(1)}{e / (1 + nu):.12g}{m.group(3)}{m.group(4)}{m.group(5)}{m.group(6)}{m.group(7)}\n"
    out.append(line)
open(sys.argv[2], "w").writelines(out)
EOF
    grep -E "wall/gran" "$matched"
    run_lammps wall-matched 1 1 "$matched" lmp || echo "LAMMPS wall-matched variant failed: skipped"
  fi
fi

# ---------------------------------------------------------------- analysis
/usr/bin/python3 "$here/analyze_pour.py" --workdir "$workdir" --csv "$csv" --dt "$dt" --ke-every "$ke_every"
