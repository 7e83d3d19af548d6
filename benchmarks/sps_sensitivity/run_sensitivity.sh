#!/usr/bin/env bash
# Sensitivity of the SPS pipeline's conductivities to the NiAl sintering parameters:
# configs/sps_nial_small.json with ONE parameter changed at a time (same seed, so the same packing),
# in the sintering law of both the cold press ("heat") and the hot press (override beside the
# "$include"), or the temperature_history expansion coefficient of both stages. The baseline runs
# first and calibrates the grain-boundary layer (gb_thickness) on porosity 0.164; the variants keep
# that layer fixed (conductivity_gb becomes a plain snapshot sweep at the baseline's gb_thickness).
# analyze_sensitivity.py then tabulates, per variant and snapshot: porosity taken, physical time
# and temperature of the snapshot, mean a/r_min of the necks, kappa_eff with / without the layer
# and their change against the baseline. Usage:
#   run_sensitivity.sh --sparkdem build/sparkdem [--variants "baseline surface_energy=0.9 ..."]
#                      [--workdir DIR] [--csv FILE] [--reuse]
# A variant is PARAMETER=VALUE (a sintering-law parameter, or expansion_coefficient); "baseline"
# is always run (first). --reuse skips the runs whose out/summary.json exists with the same scene.
set -euo pipefail
source "$(dirname "$0")/../sps_bench.sh"
variants="surface_energy=0.9 surface_energy=3.6 dihedral_angle=2.44 dihedral_angle=2.79
  gb_diffusivity_prefactor=2e-4 gb_diffusivity_prefactor=2e-2 gb_activation_energy=175000
  gb_activation_energy=215000 youngs_modulus=1.11e10 expansion_coefficient=0"
reuse=0
sps_setup sps_sensitivity "$0 --sparkdem BIN [--variants \"P=V ...\"] [--workdir DIR] [--csv FILE] [--reuse]" \
  "sparkdem variants workdir csv" "reuse" "$@"

# run VARIANT [GB_THICKNESS]: writes $workdir/VARIANT/scene.json and runs it (one thread).
run() {
  local dir="$workdir/${1//=/_}"
  mkdir -p "$dir"
  (cd "$root" && /usr/bin/python3 - "$root/configs" "$dir/scene.new.json" "$1" "${2:-}") <<'PY'
import json, os, sys
cfgdir, dst, variant, gb = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
from tools.sps_outputs import absolute_includes  # run from the repository root
j = json.load(open(os.path.join(cfgdir, "sps_nial_small.json")))
absolute_includes(j, cfgdir)  # the scene is written elsewhere
stages = {s["name"]: s for s in j["stages"]}
if variant != "baseline":
    key, value = variant.split("=")
    for name in ("heat", "hot_press"):
        target = (stages[name]["modules"]["temperature_history"] if key == "expansion_coefficient"
                  else stages[name]["contact"]["params"])
        assert key in target or "$include" in target, (name, key)
        target[key] = float(value)
    gb_stage = stages["conductivity_gb"]
    gb_stage["sweep"] = {"snapshots_of": "hot_press"}
    gb_stage["modules"]["electrical_network"]["gb_thickness"] = float(gb)
json.dump(j, open(dst, "w"), indent=1)
PY
  if [ "$reuse" = 1 ] && [ -f "$dir/out/summary.json" ] && [ -f "$dir/time.txt" ] && cmp -s "$dir/scene.new.json" "$dir/scene.json"; then
    echo "$1: reused"
  else
    mv "$dir/scene.new.json" "$dir/scene.json"
    sps_run "$dir/scene.json" "$dir"
  fi
  rm -f "$dir/scene.new.json"
  echo "$1" > "$dir/variant.txt"
  runs+=("$dir")
}

runs=()
run baseline
gb=$(/usr/bin/python3 -c 'import json, sys; print(next(s for s in json.load(open(sys.argv[1]))["stages"]
     if s["name"] == "conductivity_gb")["sweep"]["calibration"]["value"])' "$workdir/baseline/out/summary.json")
echo "baseline calibrated gb_thickness = $gb m (fixed in the variants)"
for v in $variants; do
  [ "$v" = baseline ] || run "$v" "$gb"
done
cd "$root" && /usr/bin/python3 -m benchmarks.sps_sensitivity.analyze_sensitivity --csv "$csv" "${runs[@]}"
