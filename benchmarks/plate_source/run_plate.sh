#!/usr/bin/env bash
# Thick-plate validation of seed 001 (§3.2): runs configs/plate_source.json for each N and seed
# (one thread, OMP_WAIT_POLICY=PASSIVE), times each run (wall and CPU time, GNU /usr/bin/time),
# then calls bench_plate, which computes the
# finite-difference reference (grid convergence + Richardson) and the DEM potentials at the control
# points, and writes results.csv and fd_convergence.csv. See benchmarks/README.md.
#
#   run_plate.sh --sparkdem build/sparkdem --bench build/benchmarks/plate_source/bench_plate \
#                [--particles "5000 10000 20000"] [--seeds "1"] [--workdir DIR] [--csv FILE]
#                [--fd-csv FILE] [--fd-grids "120 240 480 960"] [--skip-existing]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
sparkdem=""; bench=""; particles="5000 10000 20000"; seeds="1"; workdir=""; csv="$here/results.csv"
fdcsv="$here/fd_convergence.csv"; fdgrids="120 240 480 960"; skip=0
while [[ $# -gt 0 ]]; do
  case "$1" in
    --sparkdem) sparkdem="$2"; shift 2 ;;
    --bench) bench="$2"; shift 2 ;;
    --particles) particles="$2"; shift 2 ;;
    --seeds) seeds="$2"; shift 2 ;;
    --workdir) workdir="$2"; shift 2 ;;
    --csv) csv="$2"; shift 2 ;;
    --fd-csv) fdcsv="$2"; shift 2 ;;
    --fd-grids) fdgrids="$2"; shift 2 ;;
    --skip-existing) skip=1; shift ;;
    *) echo "unknown option $1" >&2; exit 2 ;;
  esac
done
[[ -x "$sparkdem" && -x "$bench" ]] || { echo "need --sparkdem and --bench executables" >&2; exit 2; }
workdir="${workdir:-$(mktemp -d "${TMPDIR:-/tmp}/plate_source.XXXXXX")}"
mkdir -p "$workdir"
echo "workdir: $workdir; load average: $(cut -d' ' -f1-3 /proc/loadavg); cores: $(nproc)"
dirs=()
for n in $particles; do
  for s in $seeds; do
    d="$workdir/N${n}_seed${s}"
    dirs+=("$d")
    if [[ $skip -eq 1 && -f "$d/wall_time_s" ]]; then echo "N=$n seed=$s: kept"; continue; fi
    rm -rf "$d"; mkdir -p "$d"
    python3 - "$root/configs/plate_source.json" "$d/scene.json" "$n" "$s" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
j["seed"] = int(sys.argv[4])
j["name"] = "plate_source_N%s_seed%s" % (sys.argv[3], sys.argv[4])
j["stages"][0]["generator"]["particles"] = int(sys.argv[3])
json.dump(j, open(sys.argv[2], "w"), indent=2)
PY
    OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE /usr/bin/time -f "%e %U %S" -o "$d/time.txt" \
      "$sparkdem" run "$d/scene.json" -o "$d/out" --threads 1 --quiet
    read -r wall user sys < "$d/time.txt"
    echo "$wall" > "$d/wall_time_s"
    python3 -c "print(f'{$user + $sys:.2f}')" > "$d/cpu_time_s"
    echo "N=$n seed=$s: wall $wall s, cpu $(cat "$d/cpu_time_s") s; load average $(cut -d' ' -f1-3 /proc/loadavg)"
  done
done
"$bench" --csv "$csv" --fd-csv "$fdcsv" --fd-grids "$fdgrids" "${dirs[@]}"
