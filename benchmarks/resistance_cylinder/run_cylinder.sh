#!/usr/bin/env bash
# Seed 001's cylinder resistance validation (Hubert et al. 2017, section 3.1): for each particle
# count N and packing seed, runs `sparkdem run` on a copy of configs/resistance_cylinder.json with
# only the fill generator's `particles` and the top-level `seed` changed, then tabulates R_DEM
# against R_th = rho_e (l_d - 2 r_mean) / (pi r_d^2) (analyze_cylinder.py) into results.csv and
# results.md, next to GranOO's Table III.
#
#   benchmarks/resistance_cylinder/run_cylinder.sh [--sizes "1000 2000 5000 10000 20000"]
#        [--seeds "1 2 3"] [--sparkdem PATH] [--config FILE] [--workdir DIR] [--outdir DIR]
#        [--threads N] [--wait-policy active|passive] [--reuse] [--variants] [--analyze-only]
#
#   --sizes LIST     particle counts N (default "1000 2000 5000 10000 20000")
#   --seeds LIST     packing seeds (top-level "seed"; default "1 2 3")
#   --sparkdem PATH  executable (default: $SPARKDEM_BIN, else <repo>/build/sparkdem)
#   --config FILE    scenario (default <repo>/configs/resistance_cylinder.json)
#   --workdir DIR    run directories DIR/N<N>_seed<S>/ (default: a new directory under ${TMPDIR:-/tmp})
#   --outdir DIR     where results.csv / results.md / variants.csv go (default: this directory)
#   --threads N      OpenMP threads (default 1)
#   --wait-policy P  export OMP_WAIT_POLICY=P (passive on a machine shared with other jobs)
#   --reuse          keep a run whose scenario.json is unchanged and whose summary.json says completed
#   --variants       also re-solve every finished packing (from its final_state.h5, no new fill)
#                    with diagnostic variants of the electrical model -> variants.csv; these are
#                    diagnostics next to the result, never the result
#   --analyze-only   run nothing; tabulate the run directories already in --workdir
#
# Every run directory holds scenario.json, sparkdem.log, out/ (the sparkdem output) and
# bench_meta.txt (load average at start and end; process wall, user and system time from GNU time).
# The fill is the expensive part: its cost grows as N^(4/3) (N particles, steps ~ 1/r_mean for the
# scenario's fixed 0.2 s of simulated time). See benchmarks/README.md for measured run times.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
sizes="1000 2000 5000 10000 20000"
seeds="1 2 3"
sparkdem="${SPARKDEM_BIN:-$repo/build/sparkdem}"
config="$repo/configs/resistance_cylinder.json"
workdir=""
outdir="$here"
threads=1
wait_policy=""
reuse=0
variants=0
analyze_only=0

while [[ $# -gt 0 ]]; do
  case "$1" in
    --sizes) sizes="$2"; shift 2 ;;
    --seeds) seeds="$2"; shift 2 ;;
    --sparkdem) sparkdem="$2"; shift 2 ;;
    --config) config="$2"; shift 2 ;;
    --workdir) workdir="$2"; shift 2 ;;
    --outdir) outdir="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    --wait-policy) wait_policy="$2"; shift 2 ;;
    --reuse) reuse=1; shift ;;
    --variants) variants=1; shift ;;
    --analyze-only) analyze_only=1; shift ;;
    -h|--help) sed -n '2,30p' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) echo "run_cylinder.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done

[[ "$threads" =~ ^[1-9][0-9]*$ ]] || { echo "run_cylinder.sh: --threads must be a positive integer" >&2; exit 2; }
[[ -f "$config" ]] || { echo "run_cylinder.sh: scenario $config not found" >&2; exit 2; }
[[ -z "$wait_policy" || "$wait_policy" == active || "$wait_policy" == passive ]] ||
  { echo "run_cylinder.sh: --wait-policy must be active or passive" >&2; exit 2; }
command -v h5dump > /dev/null || { echo "run_cylinder.sh: needs h5dump (Debian: hdf5-tools)" >&2; exit 2; }
if [[ $analyze_only -eq 0 || $variants -eq 1 ]]; then
  [[ -x "$sparkdem" ]] || { echo "run_cylinder.sh: sparkdem executable not found at $sparkdem (build it, or pass --sparkdem / set SPARKDEM_BIN)" >&2; exit 2; }
  [[ -x /usr/bin/time ]] || { echo "run_cylinder.sh: needs GNU time at /usr/bin/time (Debian: apt-get install time)" >&2; exit 2; }
fi
if [[ -z "$workdir" ]]; then
  [[ $analyze_only -eq 0 ]] || { echo "run_cylinder.sh: --analyze-only needs --workdir" >&2; exit 2; }
  workdir="$(mktemp -d "${TMPDIR:-/tmp}/sparkdem_bench_cylinder.XXXXXX")"
fi
mkdir -p "$workdir" "$outdir"
envs=(OMP_NUM_THREADS="$threads")
[[ -n "$wait_policy" ]] && envs+=(OMP_WAIT_POLICY="$wait_policy")

echo "cylinder resistance benchmark: N = $sizes, seeds = $seeds, workdir $workdir"
echo "machine: $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg) (timings are noisy on a shared machine)"

if [[ $analyze_only -eq 0 ]]; then
  for n in $sizes; do
    for seed in $seeds; do
      d="$workdir/N${n}_seed${seed}"
      mkdir -p "$d"
      # The only changes to the scenario: the particle count and the seed.
      python3 - "$config" "$d/scenario.json.new" "$n" "$seed" <<'EOF'
import json, sys
src, dst, n, seed = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
c = json.load(open(src))
c["seed"] = seed
fills = [st for st in c["stages"] if st.get("type") == "fill"]
if len(fills) != 1:
    sys.exit(f"{src}: expected exactly one fill stage, found {len(fills)}")
fills[0]["generator"]["particles"] = n
json.dump(c, open(dst, "w"), indent=1)
EOF
      if [[ $reuse -eq 1 && -f "$d/scenario.json" && -f "$d/out/summary.json" ]] &&
         cmp -s "$d/scenario.json" "$d/scenario.json.new" &&
         python3 -c 'import json,sys; sys.exit(json.load(open(sys.argv[1])).get("status") != "completed")' "$d/out/summary.json"; then
        rm -f "$d/scenario.json.new"
        echo "-- N=$n seed=$seed: reusing $d"
        continue
      fi
      mv "$d/scenario.json.new" "$d/scenario.json"
      rm -rf "$d/out"
      echo "-- N=$n seed=$seed: ${envs[*]} $sparkdem run $d/scenario.json -o $d/out --threads $threads --quiet"
      echo "load_start $(cut -d' ' -f1-3 /proc/loadavg)" > "$d/bench_meta.txt"
      status=0
      env "${envs[@]}" /usr/bin/time -f "time_wall_user_sys %e %U %S" -a -o "$d/bench_meta.txt" \
        "$sparkdem" run "$d/scenario.json" -o "$d/out" --threads "$threads" --quiet > "$d/sparkdem.log" 2>&1 || status=$?
      echo "exit $status" >> "$d/bench_meta.txt"
      echo "load_end $(cut -d' ' -f1-3 /proc/loadavg)" >> "$d/bench_meta.txt"
      if [[ $status -ne 0 ]]; then
        echo "   sparkdem exited with $status (see $d/sparkdem.log); the row is marked failed" >&2
        tail -5 "$d/sparkdem.log" >&2
      else
        grep time_wall_user_sys "$d/bench_meta.txt" | sed 's/^/   /'
      fi
    done
  done
fi

if [[ $variants -eq 1 ]]; then
  # Diagnostics: the same packing (final_state.h5 of each run), re-solved with one change each.
  for d in "$workdir"/N*_seed*/; do
    d="${d%/}"
    [[ -f "$d/out/final_state.h5" && -f "$d/out/summary.json" ]] || continue
    python3 "$here/analyze_cylinder.py" variant-scenario "$d" > "$d/variants.json"
    rm -rf "$d/variants"
    status=0
    env "${envs[@]}" "$sparkdem" run "$d/variants.json" -o "$d/variants" --threads "$threads" --quiet \
      > "$d/variants.log" 2>&1 || status=$?
    [[ $status -eq 0 ]] || { echo "   variants of $d: sparkdem exited with $status (see $d/variants.log)" >&2; }
  done
fi

python3 "$here/analyze_cylinder.py" tabulate "$workdir" "$outdir"
