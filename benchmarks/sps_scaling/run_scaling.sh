#!/usr/bin/env bash
# The hot press's error against run time: configs/sps_nial_small.json at three time scalings
# (factor 3.3 and 10 apart), everything else unchanged; analyze_scaling.py compares porosity
# against temperature, the snapshot porosities, their neck-size histograms, the conductivities
# and the kinetic-energy / punch-work ratio. Usage:
#   run_scaling.sh --sparkdem build/sparkdem [--scales "4e5 1.2e5 4e4"] [--workdir DIR] [--csv FILE]
set -euo pipefail
source "$(dirname "$0")/../sps_bench.sh"
scales="4e5 1.2e5 4e4"
sps_setup sps_scaling "$0 --sparkdem BIN [--scales \"4e5 1.2e5 4e4\"] [--workdir DIR] [--csv FILE]" "sparkdem scales workdir csv" "" "$@"
runs=()
for s in $scales; do
  dir="$workdir/ts_$s"
  mkdir -p "$dir"
  # Same scenario, only the hot press's time_scale and (so that the same physical cycle is
  # simulated) its mechanical stop time change.
  (cd "$root" && /usr/bin/python3 - "$root/configs/sps_nial_small.json" "$dir/scene.json" "$s" "$root/configs") <<'PY'
import json, sys
src, dst, ts, cfgdir = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]
from tools.sps_outputs import absolute_includes  # run from the repository root
j = json.load(open(src))
absolute_includes(j, cfgdir)  # the scene is written elsewhere
for st in j["stages"]:
    if st["name"] == "hot_press":
        cycle_end = max(st["modules"]["temperature_history"]["time"])
        st["time_scale"] = ts
        st["stop"]["time"] = cycle_end / ts
json.dump(j, open(dst, "w"), indent=1)
PY
  sps_run "$dir/scene.json" "$dir"
  runs+=("$dir")
done
cd "$root" && /usr/bin/python3 -m benchmarks.sps_scaling.analyze_scaling --csv "$csv" "${runs[@]}"
