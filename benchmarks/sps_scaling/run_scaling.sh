#!/usr/bin/env bash
# The hot press's error against run time: configs/sps_nial_small.json at three time scalings
# (factor 3.3 and 10 apart), everything else unchanged; analyze_scaling.py compares porosity
# against temperature, the snapshot porosities, their neck-size histograms, the conductivities
# and the kinetic-energy / punch-work ratio. Usage:
#   run_scaling.sh --sparkdem build/sparkdem [--scales "4e5 1.2e5 4e4"] [--workdir DIR] [--csv FILE]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
sparkdem=""
scales="4e5 1.2e5 4e4"
workdir=""
csv="$here/results.csv"
while [ $# -gt 0 ]; do
  case "$1" in
    --sparkdem) sparkdem=$2; shift 2 ;;
    --scales) scales=$2; shift 2 ;;
    --workdir) workdir=$2; shift 2 ;;
    --csv) csv=$2; shift 2 ;;
    *) echo "usage: $0 --sparkdem BIN [--scales \"4e5 1.2e5 4e4\"] [--workdir DIR] [--csv FILE]" >&2; exit 2 ;;
  esac
done
[ -x "$sparkdem" ] || { echo "give --sparkdem PATH (an executable)" >&2; exit 2; }
[ -n "$workdir" ] || workdir=$(mktemp -d "${TMPDIR:-/tmp}/sps_scaling.XXXXXX")
mkdir -p "$workdir"
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg); workdir $workdir"
runs=()
for s in $scales; do
  dir="$workdir/ts_$s"
  mkdir -p "$dir"
  # Same scenario, only the hot press's time_scale and (so that the same physical cycle is
  # simulated) its mechanical stop time change.
  /usr/bin/python3 - "$root/configs/sps_nial_small.json" "$dir/scene.json" "$s" "$root/configs" <<'PY'
import json, sys
src, dst, ts, cfgdir = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]
j = json.load(open(src))
for st in j["stages"]:
    if st["name"] == "hot_press":
        cycle_end = max(st["modules"]["temperature_history"]["time"])
        st["time_scale"] = ts
        st["stop"]["time"] = cycle_end / ts
def absolute_includes(x):
    """Every "$include" made absolute (the variant scene is written elsewhere)."""
    if isinstance(x, dict):
        return {k: (cfgdir + "/" + v if k == "$include" else absolute_includes(v)) for k, v in x.items()}
    if isinstance(x, list):
        return [absolute_includes(v) for v in x]
    return x
json.dump(absolute_includes(j), open(dst, "w"), indent=1)
PY
  OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE /usr/bin/time -f "%e %U %S" -o "$dir/time.txt" \
    "$sparkdem" run "$dir/scene.json" -o "$dir/out" --threads 1 --quiet
  runs+=("$dir")
done
/usr/bin/python3 "$here/analyze_scaling.py" --csv "$csv" "${runs[@]}"
