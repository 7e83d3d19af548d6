#!/usr/bin/env bash
# NiAl deposit benchmark: runs `sparkdem run configs/pack_deposit_nial.json` once and reports wall
# time, particle-steps/s (from summary.json), peak memory (/usr/bin/time -v "Maximum resident set
# size") and memory per particle, into benchmarks/nial_deposit/results.csv.
#
#   benchmarks/nial_deposit/run_nial.sh [--threads N] [--sparkdem PATH] [--config FILE]
#                                       [--workdir DIR] [--csv FILE] [--wait-policy active|passive]
#                                       [--stop-time T]
#
#   --threads N      OpenMP threads (default 1; sets OMP_NUM_THREADS and --threads)
#   --sparkdem PATH  executable (default: $SPARKDEM_BIN, else <repo>/build/sparkdem)
#   --config FILE    scenario (default <repo>/configs/pack_deposit_nial.json)
#   --workdir DIR    output directory parent (default: a new directory under ${TMPDIR:-/tmp})
#   --csv FILE       results table (default benchmarks/nial_deposit/results.csv; a row is appended,
#                    the file is rewritten through FILE.tmp and a rename)
#   --wait-policy P  export OMP_WAIT_POLICY=P (use passive on a machine shared with other jobs)
#   --stop-time T    smoke test: run a copy of the scenario whose every stage stops at simulated time
#                    T [s] without requiring its `until` (the row's config gets the suffix @T)
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
threads=1
sparkdem="${SPARKDEM_BIN:-$repo/build/sparkdem}"
config="$repo/configs/pack_deposit_nial.json"
workdir=""
csv="$here/results.csv"
wait_policy=""
stop_time=""

while [[ $# -gt 0 ]]; do
  case "$1" in
    --threads) threads="$2"; shift 2 ;;
    --sparkdem) sparkdem="$2"; shift 2 ;;
    --config) config="$2"; shift 2 ;;
    --workdir) workdir="$2"; shift 2 ;;
    --csv) csv="$2"; shift 2 ;;
    --wait-policy) wait_policy="$2"; shift 2 ;;
    --stop-time) stop_time="$2"; shift 2 ;;
    -h|--help) sed -n '2,18p' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) echo "run_nial.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done

[[ "$threads" =~ ^[1-9][0-9]*$ ]] || { echo "run_nial.sh: --threads must be a positive integer" >&2; exit 2; }
[[ -x "$sparkdem" ]] || { echo "run_nial.sh: sparkdem executable not found at $sparkdem (build it, or pass --sparkdem / set SPARKDEM_BIN)" >&2; exit 2; }
[[ -f "$config" ]] || { echo "run_nial.sh: scenario $config not found" >&2; exit 2; }
[[ -x /usr/bin/time ]] || { echo "run_nial.sh: needs GNU time at /usr/bin/time (Debian: apt-get install time)" >&2; exit 2; }
[[ -z "$wait_policy" || "$wait_policy" == active || "$wait_policy" == passive ]] ||
  { echo "run_nial.sh: --wait-policy must be active or passive" >&2; exit 2; }

[[ -n "$workdir" ]] || workdir="$(mktemp -d "${TMPDIR:-/tmp}/sparkdem_bench_nial.XXXXXX")"
mkdir -p "$workdir"
out="$workdir/nial_t$threads"
rm -rf "$out"
label="$(basename "$config")"
if [[ -n "$stop_time" ]]; then
  short="$workdir/$(basename "$config" .json)_stop$stop_time.json"
  python3 - "$config" "$short" "$stop_time" <<'EOF'
import json, sys
c = json.load(open(sys.argv[1]))
for st in c["stages"]:
    st.setdefault("stop", {})
    st["stop"]["time"] = float(sys.argv[3])
    st["stop"]["require_until"] = False
json.dump(c, open(sys.argv[2], "w"), indent=1)
EOF
  config="$short"
  label="$label@$stop_time"
fi
envs=(OMP_NUM_THREADS="$threads")
[[ -n "$wait_policy" ]] && envs+=(OMP_WAIT_POLICY="$wait_policy")

echo "NiAl deposit benchmark: $config, $threads thread(s), output $out"
echo "machine: $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg) (timings are noisy on a shared machine)"

# Baseline resident set of the executable alone (libraries, HDF5, registry): `sparkdem schema`.
/usr/bin/time -v -o "$workdir/time_baseline.txt" "$sparkdem" schema > /dev/null
echo "-- ${envs[*]} $sparkdem run $config -o $out --threads $threads --quiet"
status=0
env "${envs[@]}" /usr/bin/time -v -o "$workdir/time_run.txt" \
  "$sparkdem" run "$config" -o "$out" --threads "$threads" --quiet > "$workdir/run.log" 2>&1 || status=$?
if [[ $status -ne 0 ]]; then
  echo "sparkdem exited with $status (see $workdir/run.log):" >&2
  tail -20 "$workdir/run.log" >&2
  exit 1
fi

python3 - "$workdir/time_baseline.txt" "$workdir/time_run.txt" "$out/summary.json" "$csv" "$threads" \
  "${wait_policy:-default}" "$label" <<'EOF'
import csv, json, os, re, sys
base_f, run_f, summary_f, csv_f, threads, policy, config = sys.argv[1:]

def gnu_time(path):
    t = open(path).read()
    rss_kb = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", t).group(1))
    m = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", t).group(1).split(":")
    wall = sum(float(x) * 60 ** k for k, x in enumerate(reversed(m)))
    return rss_kb, wall

base_kb, _ = gnu_time(base_f)
peak_kb, wall = gnu_time(run_f)
s = json.load(open(summary_f))
n = int(s["particles"])
row = {
    "config": config, "threads": threads, "omp_wait_policy": policy, "particles": n, "steps": s["steps"],
    "wall_s": f"{wall:.2f}", "run_wall_s": f"{s['wall_time_s']:.2f}",
    "particle_steps_per_s": f"{s['particle_steps_per_s']:.6g}",
    "peak_rss_MiB": f"{peak_kb / 1024:.1f}", "baseline_rss_MiB": f"{base_kb / 1024:.1f}",
    "bytes_per_particle": f"{peak_kb * 1024 / n:.0f}" if n else "nan",
    "net_bytes_per_particle": f"{(peak_kb - base_kb) * 1024 / n:.0f}" if n else "nan",
    "status": s.get("status", "?"),
}
rows = []
if os.path.exists(csv_f):
    with open(csv_f) as f:
        rows = [r for r in csv.DictReader(f) if list(r) == list(row)]
rows.append(row)
tmp = csv_f + ".tmp"
with open(tmp, "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(row))
    w.writeheader()
    w.writerows(rows)
os.replace(tmp, csv_f)

print(f"\n== NiAl deposit: {n} particles, {s['steps']} steps, {threads} thread(s), status {row['status']} ==")
print(f"wall time (process)      {wall:10.2f} s   (sparkdem's own: {s['wall_time_s']:.2f} s)")
print(f"particle-steps/s         {s['particle_steps_per_s']:10.4g}     (all stages: particles x steps / run wall time)")
for st in s["stages"]:
    if "particle_steps_per_s" in st:
        print(f"  stage {st['name']:<12s} {st.get('steps', 0):>9} steps  {st.get('wall_time_s', 0):9.2f} s  "
              f"{st['particle_steps_per_s']:10.4g} particle-steps/s")
print(f"peak resident memory     {peak_kb / 1024:10.1f} MiB (baseline `sparkdem schema`: {base_kb / 1024:.1f} MiB)")
print(f"memory per particle      {peak_kb * 1024 / n:10.0f} B   (net of the baseline: {(peak_kb - base_kb) * 1024 / n:.0f} B)")
print(f"wrote {csv_f}")
EOF
