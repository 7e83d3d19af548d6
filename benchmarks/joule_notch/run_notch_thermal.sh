#!/usr/bin/env bash
# Notched rod with Joule heating (seed 001 section 3.3, second case; cohesive-joule-torsion.md 7.4)
# at several particle counts: for each N (particles before the slots are cut)
#   1. pack: `sparkdem run` on configs/joule_notch_pack.json with `particles` = N (generator
#      "fill" as shipped, or "relax": the same box packed by the relax generator, max_overlap
#      0.005, max_iterations 20000 - a cheaper packing, reported as a variant);
#   2. reference: tools/fv_notch/compare_notch.py on the packing (FV planes at the end sets' mean
#      centre heights, slab 2 r_mean), written to <run>_compare.json BEFORE the thermal run;
#   3. thermal: thermal_scenario.py -> configs/joule_notch.json's joule stage from the packing's
#      final_state.h5, with the references of step 2 as its checks; `sparkdem run`;
#   4. record_thermal.py -> <run>_record.json (errors, wall times).
#
#   benchmarks/joule_notch/run_notch_thermal.sh [--sizes "5166 10332"] [--generator fill|relax]
#        [--sparkdem PATH] [--fv PATH] [--workdir DIR] [--threads N]
#
# Then: record_thermal.py tabulate LABEL=DIR/<run>_record.json ... > thermal_results.md
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
sizes="5166 10332"
generator="fill"
sparkdem="${SPARKDEM_BIN:-$repo/build/sparkdem}"
fv="$repo/build/tools/fv_notch"
workdir=""
threads=1
while [[ $# -gt 0 ]]; do
  case "$1" in
    --sizes) sizes="$2"; shift 2 ;;
    --generator) generator="$2"; shift 2 ;;
    --sparkdem) sparkdem="$2"; shift 2 ;;
    --fv) fv="$2"; shift 2 ;;
    --workdir) workdir="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    -h|--help) sed -n '2,19p' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) echo "run_notch_thermal.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
[[ "$generator" == fill || "$generator" == relax ]] || { echo "run_notch_thermal.sh: --generator fill|relax" >&2; exit 2; }
[[ -x "$sparkdem" && -x "$fv" ]] || { echo "run_notch_thermal.sh: needs $sparkdem and $fv (build them)" >&2; exit 2; }
[[ -n "$workdir" ]] || workdir="$(mktemp -d "${TMPDIR:-/tmp}/sparkdem_bench_notch.XXXXXX")"
mkdir -p "$workdir"
cd "$workdir"
export OMP_NUM_THREADS="$threads"
for n in $sizes; do
  d="notch_${generator}_n$n"
  python3 - "$repo/configs/joule_notch_pack.json" "$n" "$generator" > "$d.pack.json" <<'PY'
import json, sys
src, n, gen = sys.argv[1], int(sys.argv[2]), sys.argv[3]
c = json.load(open(src))
f = c["stages"][0]["generator"]
if gen == "fill":
    f["particles"] = n
else:
    c["stages"][0] = {"name": "cook", "type": "relax",
                      "generator": {"shape": "box", "lo": f["lo"], "hi": f["hi"], "particles": n, "spread": f["spread"],
                                    "target_density": f["target_density"], "density": 7900, "max_overlap": 0.005,
                                    "max_iterations": 20000}}
json.dump(c, sys.stdout, indent=1)
PY
  echo "-- $d: pack"
  echo "load_start $(cut -d' ' -f1-3 /proc/loadavg)" > "$d.pack.meta"
  /usr/bin/time -f "time_wall_user_sys %e %U %S" -a -o "$d.pack.meta" "$sparkdem" run "$d.pack.json" -o "${d}_pack" \
    --threads "$threads" --quiet > "$d.pack.log" 2>&1 || { echo "   pack failed (see $d.pack.log)" >&2; continue; }
  echo "-- $d: FV reference"
  python3 "$repo/tools/fv_notch/compare_notch.py" "${d}_pack" --fv "$fv" > "${d}_compare.json"
  python3 "$here/thermal_scenario.py" "${d}_pack" "${d}_compare.json" > "${d}_thermal.json"
  echo "-- $d: thermal"
  echo "load_start $(cut -d' ' -f1-3 /proc/loadavg)" > "$d.thermal.meta"
  /usr/bin/time -f "time_wall_user_sys %e %U %S" -a -o "$d.thermal.meta" "$sparkdem" run "${d}_thermal.json" -o "${d}_thermal" \
    --threads "$threads" --quiet --report-only > "$d.thermal.log" 2>&1 || { echo "   thermal failed (see $d.thermal.log)" >&2; continue; }
  python3 "$here/record_thermal.py" "${d}_thermal" "${d}_compare.json" "$d.thermal.meta" > "${d}_record.json"
  grep -E '"(R_error_pct|rise_error_pct)"' "${d}_record.json" | sed 's/^/   /'
done
