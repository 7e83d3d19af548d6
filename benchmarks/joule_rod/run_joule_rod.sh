#!/usr/bin/env bash
# Seed 001's Joule-heated uniform rod (Hubert et al. 2017, section 3.3, first case;
# cohesive-joule-torsion.md 7.3): for each particle count N, runs `sparkdem run` on a copy of
# configs/joule_rod.json with only the relax generator's `particles` and the check's reference
# changed (analytic rise dV^2 t / (R_th rho c V), R_th with r_mean of Eq. 1 for that N, computed
# and written into the copy before the run), plus two extra frozen stages on the same packing
# that repeat the joule stage with capacity "sphere" and "volume_fraction" (the config's own
# stage uses "domain"). analyze_joule_rod.py tabulates results.csv and results.md.
#
#   benchmarks/joule_rod/run_joule_rod.sh [--sizes "5000 10000 20000"] [--seed S]
#        [--max-iterations K] [--max-overlap X] [--sparkdem PATH] [--config FILE]
#        [--workdir DIR] [--outdir DIR] [--threads N] [--wait-policy active|passive]
#        [--reuse] [--analyze-only]
#
#   --sizes LIST        particle counts N (default "5000 10000 20000")
#   --seed S            packing seed (top-level "seed"; default: the config's, 1)
#   --max-iterations K  relax generator's FIRE iteration limit (default: the config's, 20000)
#   --max-overlap X     relax generator's overlap stop criterion (default: the config's, 0.005)
#                       These two change only when the packing stops (its quality and its cost,
#                       not the physics); the run directory name records them and results.csv
#                       carries the packing's reached overlap, force and iterations per row.
#   --sparkdem PATH     executable (default: $SPARKDEM_BIN, else <repo>/build/sparkdem)
#   --config FILE       scenario (default <repo>/configs/joule_rod.json)
#   --workdir DIR       run directories DIR/N<N>_seed<S>_it<K>_ov<X>/ (default: a new directory under ${TMPDIR:-/tmp})
#   --outdir DIR        where results.csv / results.md go (default: this directory)
#   --threads N         OpenMP threads (default 1)
#   --wait-policy P     export OMP_WAIT_POLICY=P (passive on a machine shared with other jobs)
#   --reuse             keep a run whose scenario.json is unchanged and whose summary.json says completed
#   --analyze-only      run nothing; tabulate the run directories already in --workdir
#
# Every run directory holds scenario.json, sparkdem.log, out/ and bench_meta.txt (load average at
# start and end; process wall, user and system time from GNU time). The relax packing is the
# expensive part (about 29 ms per FIRE iteration at N = 5000 with one thread; the cost per
# iteration grows as N); the three joule stages take seconds.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
sizes="5000 10000 20000"
seed=""
max_it=""
max_ov=""
sparkdem="${SPARKDEM_BIN:-$repo/build/sparkdem}"
config="$repo/configs/joule_rod.json"
workdir=""
outdir="$here"
threads=1
wait_policy=""
reuse=0
analyze_only=0

while [[ $# -gt 0 ]]; do
  case "$1" in
    --sizes) sizes="$2"; shift 2 ;;
    --seed) seed="$2"; shift 2 ;;
    --max-iterations) max_it="$2"; shift 2 ;;
    --max-overlap) max_ov="$2"; shift 2 ;;
    --sparkdem) sparkdem="$2"; shift 2 ;;
    --config) config="$2"; shift 2 ;;
    --workdir) workdir="$2"; shift 2 ;;
    --outdir) outdir="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    --wait-policy) wait_policy="$2"; shift 2 ;;
    --reuse) reuse=1; shift ;;
    --analyze-only) analyze_only=1; shift ;;
    -h|--help) sed -n '2,34p' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) echo "run_joule_rod.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done

[[ "$threads" =~ ^[1-9][0-9]*$ ]] || { echo "run_joule_rod.sh: --threads must be a positive integer" >&2; exit 2; }
[[ -f "$config" ]] || { echo "run_joule_rod.sh: scenario $config not found" >&2; exit 2; }
[[ -z "$wait_policy" || "$wait_policy" == active || "$wait_policy" == passive ]] ||
  { echo "run_joule_rod.sh: --wait-policy must be active or passive" >&2; exit 2; }
if [[ $analyze_only -eq 0 ]]; then
  [[ -x "$sparkdem" ]] || { echo "run_joule_rod.sh: sparkdem executable not found at $sparkdem (build it, or pass --sparkdem / set SPARKDEM_BIN)" >&2; exit 2; }
  [[ -x /usr/bin/time ]] || { echo "run_joule_rod.sh: needs GNU time at /usr/bin/time (Debian: apt-get install time)" >&2; exit 2; }
fi
if [[ -z "$workdir" ]]; then
  [[ $analyze_only -eq 0 ]] || { echo "run_joule_rod.sh: --analyze-only needs --workdir" >&2; exit 2; }
  workdir="$(mktemp -d "${TMPDIR:-/tmp}/sparkdem_bench_joule_rod.XXXXXX")"
fi
mkdir -p "$workdir" "$outdir"
envs=(OMP_NUM_THREADS="$threads")
[[ -n "$wait_policy" ]] && envs+=(OMP_WAIT_POLICY="$wait_policy")

echo "joule rod benchmark: N = $sizes, workdir $workdir"
echo "machine: $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg) (timings are noisy on a shared machine)"

if [[ $analyze_only -eq 0 ]]; then
  for n in $sizes; do
    name="$(python3 "$here/analyze_joule_rod.py" run-name "$config" "$n" "$seed" "$max_it" "$max_ov")"
    d="$workdir/$name"
    mkdir -p "$d"
    python3 "$here/analyze_joule_rod.py" scenario "$config" "$n" "$seed" "$max_it" "$max_ov" > "$d/scenario.json.new"
    if [[ $reuse -eq 1 && -f "$d/scenario.json" && -f "$d/out/summary.json" ]] &&
       cmp -s "$d/scenario.json" "$d/scenario.json.new" &&
       python3 -c 'import json,sys; sys.exit(json.load(open(sys.argv[1])).get("status") != "completed")' "$d/out/summary.json"; then
      rm -f "$d/scenario.json.new"
      echo "-- $name: reusing $d"
      continue
    fi
    mv "$d/scenario.json.new" "$d/scenario.json"
    rm -rf "$d/out"
    echo "-- $name: ${envs[*]} $sparkdem run $d/scenario.json -o $d/out --threads $threads --quiet --report-only"
    echo "load_start $(cut -d' ' -f1-3 /proc/loadavg)" > "$d/bench_meta.txt"
    status=0
    env "${envs[@]}" /usr/bin/time -f "time_wall_user_sys %e %U %S" -a -o "$d/bench_meta.txt" \
      "$sparkdem" run "$d/scenario.json" -o "$d/out" --threads "$threads" --quiet --report-only > "$d/sparkdem.log" 2>&1 || status=$?
    echo "exit $status" >> "$d/bench_meta.txt"
    echo "load_end $(cut -d' ' -f1-3 /proc/loadavg)" >> "$d/bench_meta.txt"
    if [[ $status -ne 0 ]]; then
      echo "   sparkdem exited with $status (see $d/sparkdem.log); the row is marked failed" >&2
      tail -5 "$d/sparkdem.log" >&2
    else
      grep time_wall_user_sys "$d/bench_meta.txt" | sed 's/^/   /'
    fi
  done
fi

python3 "$here/analyze_joule_rod.py" tabulate "$workdir" "$outdir"
