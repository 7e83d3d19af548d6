#!/usr/bin/python3
"""Simulated against measured porosity of seed 000's Table 1 samples (benchmarks/sps_table1/run_table1.sh).

Arguments K:RUN_DIR (RUN_DIR holds out/ and time.txt of a run of configs/sps_table1_sampleK.json).
From the hot press as run (out/resolved.json): Ts (the highest temperature of its
temperature_history), the pressure (the highest of the top wall), the end of the hold (the time
of the last temperature point at Ts, after which cooling starts) and dt_fraction. From
timeseries.csv (hot_press rows, physical time from the stage's start): porosity_mass at the last
row not after the end of the hold and at the last row (cooled), and their differences to the
measured porosity (simulated - measured). A run that failed (summary.json status) is reported
with its error, the physical time it reached and its last porosity; the values it did not reach
stay empty.
"""
import argparse, csv, json, os, sys
import numpy as np

from tools.sps_outputs import timeseries

MEASURED = {1: 0.216, 2: 0.164, 3: 0.106, 4: 0.050}  # seed 000, Table 1


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--csv", required=True)
    ap.add_argument("runs", nargs="+", help="K:RUN_DIR")
    a = ap.parse_args()
    with open(a.csv, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["sample", "Ts_C", "pressure_MPa", "measured_porosity", "dt_fraction", "end_of_hold_s",
                    "porosity_end_of_hold", "difference_end_of_hold", "porosity_end_cooled", "difference_end_cooled",
                    "status", "reached_s", "last_porosity", "run_wall_s"])
        for arg in a.runs:
            k, run = arg.split(":", 1)
            out = os.path.join(run, "out")
            press = next(s for s in json.load(open(os.path.join(out, "resolved.json")))["stages"] if s["name"] == "hot_press")
            hist = press["modules"]["temperature_history"]
            T = np.array(hist["temperature"])
            hold_end = hist["time"][int(np.flatnonzero(T == T.max())[-1])]
            cycle_end = hist["time"][-1]
            measured = MEASURED[int(k)]
            summary = json.load(open(os.path.join(out, "summary.json")))
            status = summary.get("status", "ok")
            if "error" in summary:
                status += ": " + summary["error"]
            ts = timeseries(out)
            stage = ts["stage"] == ts["stage"].max()  # the hot press: the last (dynamics) stage
            t = ts["physical_time"][stage] - ts["physical_time"][stage][0]
            phi = ts["porosity_mass"][stage]
            reached = t[-1] if t.size else 0.0
            hold = phi[np.flatnonzero(t <= hold_end * (1 + 1e-9))[-1]] if reached >= hold_end * (1 - 1e-6) else None
            end = phi[-1] if reached >= cycle_end * (1 - 1e-3) else None
            w.writerow([k, "%.0f" % (T.max() - 273.15), "%g" % (max(press["walls"]["top"]["pressures"]) / 1e6), measured,
                        press["dt_fraction"], hold_end]
                       + (["%.4f" % hold, "%+.4f" % (hold - measured)] if hold is not None else ["not reached", ""])
                       + (["%.4f" % end, "%+.4f" % (end - measured)] if end is not None else ["not reached", ""])
                       + [status, "%.1f" % reached, "%.4f" % phi[-1] if phi.size else "",
                          float(open(os.path.join(run, "time.txt")).read().splitlines()[-1].split()[0])])
    print(open(a.csv).read())


if __name__ == "__main__":
    sys.exit(main())
