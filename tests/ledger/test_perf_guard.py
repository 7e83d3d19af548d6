#!/usr/bin/python3
"""The perf guard of tools/perf.py (issue 40 item 6): a figure more than 10 % worse than the last
record of the same id is flagged, one within 10 % or better is not, and only time and memory units
(lower is better) are compared; since issue 63 item 4 only records of the same machine are compared
and `report` groups the records by machine. Also the beds drawn at random (issue 63 item 5) and the
share of the machine's own bound (item 2). ctest: perf/guard (label validation)."""
import json
import os
import tempfile
import unittest

from benchmarks.mechanics import random_beds
from benchmarks.perf import cases, harness
from tools import ledger as rules
from tools import perf

MACHINE = "AMD EPYC, 2 cores"


def rec(rid, value, unit="s", commit="0123456789ab", machine=MACHINE):
    r = {"id": rid, "value": value, "unit": unit, "commit": commit}
    if machine:
        r["machine"] = machine
    return r


class Guard(unittest.TestCase):
    def test_flags_over_ten_percent(self):
        flagged = perf.slowdowns([rec("a", 11.5), rec("b", 10.9), rec("c", 7.0)], [rec("a", 10.0), rec("b", 10.0), rec("c", 10.0)])
        self.assertEqual([f[0] for f in flagged], ["a"])
        rid, v0, v1, change, commit = flagged[0]
        self.assertEqual((v0, v1, commit), (10.0, 11.5, "0123456789ab"))
        self.assertAlmostEqual(change, 0.15, places=12)

    def test_memory_and_step_units(self):
        old = [rec("m", 1500.0, "B/particle"), rec("t", 1e-3, "s/step")]
        new = [rec("m", 1700.0, "B/particle"), rec("t", 1.05e-3, "s/step")]
        self.assertEqual([f[0] for f in perf.slowdowns(new, old)], ["m"])

    def test_new_ids_other_units_and_unit_changes_are_skipped(self):
        old = [rec("x", 10.0), rec("r", 1.0, "1"), rec("u", 10.0, "s")]
        new = [rec("y", 99.0), rec("r", 9.0, "1"), rec("u", 99.0, "s/step"), rec("x", None)]
        self.assertEqual(perf.slowdowns(new, old), [])

    def test_limit_is_a_parameter(self):
        self.assertEqual(len(perf.slowdowns([rec("a", 10.6)], [rec("a", 10.0)], limit=0.05)), 1)


class ByMachine(unittest.TestCase):
    """Issue 63 item 4: a figure is compared only with a record of the same machine."""

    def test_other_and_unknown_machines_are_not_compared(self):
        old = [rec("a", 10.0, machine="Intel Xeon, 2 cores"), rec("b", 10.0, machine=None), rec("c", 10.0),
               rec("d", 10.0, machine=None)]
        new = [rec("a", 20.0), rec("b", 20.0), rec("c", 20.0), rec("d", 20.0, machine=None)]
        slower, skipped = perf.guard(new, old)
        self.assertEqual([f[0] for f in slower], ["c"])
        why = dict(skipped)
        self.assertEqual(sorted(why), ["a", "b", "d"])
        self.assertIn("another machine (Intel Xeon, 2 cores", why["a"])
        self.assertIn("its record names no machine (unknown machine)", why["b"])
        self.assertIn(perf.UNKNOWN_MACHINE, why["d"])
        self.assertEqual(perf.slowdowns(new, old), slower)

    def test_kept_scenes_are_not_compared_with_themselves(self):
        # `run --scenes`: the other scenes' records come from the committed run (same measured_at)
        kept = dict(rec("k", 10.0, machine=None), measured_at="2026-11-29 03:12:29 UTC")
        fresh = dict(rec("f", 10.0, machine=None), measured_at="2026-12-02 14:30:00 UTC")
        old = [kept, dict(fresh, measured_at="2026-11-29 03:12:29 UTC")]
        self.assertEqual(perf.guard([kept, fresh], old), ([], [("f", "its record names no machine (unknown machine)")]))

    def test_ids_without_a_record_are_neither_compared_nor_listed(self):
        self.assertEqual(perf.guard([rec("new", 5.0)], [rec("old", 1.0, machine=None)]), ([], []))

    def test_cpu_model_from_cpuinfo(self):
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "cpuinfo")
            with open(path, "w") as f:
                f.write("processor\t: 0\nvendor_id\t: AuthenticAMD\nmodel name\t: AMD  EPYC 7B13\n\nprocessor\t: 1\n"
                        "model name\t: AMD EPYC 7B13\n")
            self.assertEqual(harness.cpu_model(path), "AMD EPYC 7B13")
            with open(path, "w") as f:
                f.write("processor\t: 0\nBogoMIPS\t: 50.00\n")
            self.assertEqual(harness.cpu_model(path), "unknown CPU")
            self.assertEqual(harness.cpu_model(os.path.join(d, "absent")), "unknown CPU")

    def test_machine_label(self):
        self.assertEqual(harness.machine_label({"cpu_model": "AMD EPYC", "cores": 2}), "AMD EPYC, 2 cores")
        self.assertIsNone(harness.machine_label({"cores": 2, "uname": "x"}))  # a sidecar written before issue 63
        self.assertIsNone(harness.machine_label(None))
        m = harness.machine()
        self.assertEqual(harness.machine_label(m), f"{m['cpu_model']}, {os.cpu_count()} cores")

    def test_records_take_the_machine_of_their_run(self):
        # A harness result whose sidecar names the CPU: every record names it; a scene kept from an older
        # run (`--scenes`) whose sidecar did not name it has none (an unknown machine).
        case = next(c for c in perf.case_table.CASES if c.id == "mechanics")
        src = os.path.join(perf.REPO, case.result)
        run = lambda commit, machine: dict({"versions": {"sparkdem": commit}, "load_before": [0.5], "load_after": [0.5],
                                            "load_max": 0.5, "finished": "t", "repeats": 5},
                                           **({"machine": machine} if machine else {}))
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "results.csv")
            with open(src) as f, open(path, "w") as g:
                g.write(f.read())
            meta = dict(run("new", {"cpu_model": "AMD EPYC", "cores": 2}), kept_runs={"pour": run("old", None)})
            with open(path + ".meta.json", "w") as f:
                json.dump(meta, f)
            recs = perf.records_of(case, path)
        pour = [r for r in recs if r["scene"] == "pour"]
        others = [r for r in recs if r["scene"] != "pour"]
        self.assertTrue(pour and others)
        self.assertTrue(all("machine" not in r for r in pour))
        self.assertTrue(all(r["machine"] == "AMD EPYC, 2 cores" for r in others))

    def test_report_groups_by_machine(self):
        recs = [dict(rec("perf/x/1", 1.0, machine="B, 2 cores"), case="x"), dict(rec("perf/x/2", 2.0, machine=None), case="x"),
                dict(rec("perf/x/3", 3.0, machine="A, 4 cores"), case="x"), dict(rec("perf/x/4", 4.0, machine="B, 2 cores"), case="x")]
        groups = rules.perf_by_machine(recs)
        self.assertEqual([(m, [r["id"][-1] for r in g]) for m, g in groups],
                         [("B, 2 cores", ["1", "4"]), ("A, 4 cores", ["3"]), (rules.UNKNOWN_MACHINE_NOTE, ["2"])])
        table = rules.perf_table({"perf": recs}, full=False)
        heads = [l for l in table.splitlines() if l.startswith("Machine: ")]
        self.assertEqual(heads, ["Machine: B, 2 cores", "Machine: A, 4 cores", f"Machine: {rules.UNKNOWN_MACHINE_NOTE}"])
        # each record in the table under its own machine's line
        rows = [l.split(" | ")[0].lstrip("| ") for l in table.splitlines() if l.startswith("| perf/")]
        self.assertEqual(rows, ["perf/x/1", "perf/x/4", "perf/x/3", "perf/x/2"])


class RandomBeds(unittest.TestCase):
    """Issue 63 item 5: beds drawn once at random by a seeded generator."""

    def drawn_scenes(self):
        return {n: s for n, s in cases.MECH_SCENES.items() if "draw" in s}

    def test_at_least_two_and_each_is_its_seeds_draw(self):
        drawn = self.drawn_scenes()
        self.assertGreaterEqual(len(drawn), 2)
        self.assertEqual(len({s["draw"]["seed"] for s in drawn.values()}), len(drawn))
        for name, spec in drawn.items():
            self.assertEqual(spec["draw"], random_beds.draw(spec["draw"]["seed"]), name)
            self.assertEqual(name, random_beds.name_of(spec["draw"]["seed"]))
            self.assertTrue(spec.get("packed"))
            random_beds.check(spec, perf.REPO)  # the committed scene and LAMMPS input are the draw's

    def test_draws_are_reproducible_and_in_range(self):
        for seed in list(range(1, 400)) + [6301, 6302]:
            d = random_beds.draw(seed)
            self.assertEqual(d, random_beds.draw(seed))
            self.assertIn(d["law"], ("hertz_mindlin", "lammps_hertz_tsuji", "hooke"))
            for key, (lo, hi) in random_beds.RANGES.items():
                self.assertTrue(lo <= d[key] <= hi, (seed, key, d[key]))
        laws = {random_beds.draw(s)["law"] for s in range(1, 400)}
        self.assertEqual(laws, {"hertz_mindlin", "lammps_hertz_tsuji", "hooke"})
        # Python's Mersenne Twister from an integer seed: the draw of 6301 on any CPython 3.
        self.assertEqual(random_beds.draw(6301), {"seed": 6301, "law": "hooke", "spread": 0.302, "friction": 0.258,
                                                  "skin_over_radius": 0.305})

    def test_edited_table_is_refused(self):
        spec = dict(next(iter(self.drawn_scenes().values())))
        spec["draw"] = dict(spec["draw"], friction=0.5)
        with self.assertRaises(RuntimeError):
            random_beds.check(spec, perf.REPO)

    def test_like_for_like(self):
        for spec in self.drawn_scenes().values():
            d = spec["draw"]
            sc = random_beds.scene(d)
            bed = sc["stages"][-1]
            lmp = random_beds.lammps_input(d)
            skin = d["skin_over_radius"] * random_beds.nominal_radius(d["spread"])
            self.assertAlmostEqual(bed["skin"], skin, delta=1e-9)
            self.assertIn(f"neighbor        {bed['skin']!r} bin", lmp)
            self.assertEqual(sc["stages"][0]["generator"]["spread"], d["spread"])
            self.assertEqual(bed["contact"]["params"]["friction"], d["friction"])
            self.assertEqual(lmp.count(f" {d['friction']:g} damping tsuji"), 4)  # the pair and three wall fixes
            self.assertIn(f"run             {bed['stop']['steps']}", lmp)
            self.assertIn(f"timestep        {bed['dt']:g}", lmp)

    def test_lammps_damping_matches_sparkdem(self):
        # hooke: LAMMPS's Tsuji damping of a Hooke spring, alpha(e') sqrt(m* k_n), equals sparkdem's
        # 2 (-ln e) / sqrt(pi^2 + ln^2 e) sqrt(m* k_n) for e = 0.5 (to the digits the input carries).
        e_l = float(random_beds.lammps_models({"law": "hooke", "friction": 0.5})[0].split()[2])
        self.assertAlmostEqual(random_beds.tsuji_alpha(e_l), random_beds.hooke_damping_factor(0.5), delta=1e-11)
        self.assertAlmostEqual(random_beds.hooke_damping_factor(0.5), 0.4309075239, places=9)
        # hertz_mindlin: the Tsuji e of lammps_poly_box_bed.in gives sparkdem's exact alpha(0.5) = 0.48177
        self.assertAlmostEqual(random_beds.tsuji_alpha(random_beds.TSUJI_E_HERTZ_MINDLIN_05), 0.48177, places=5)


class StreamShare(unittest.TestCase):
    """Issue 63 item 2: a 2-thread speed-up as a share of min(2, the streaming loop's speed-up)."""

    def test_share(self):
        self.assertAlmostEqual(cases.stream_share(1.5, 1.6), 1.5 / 1.6, places=14)
        self.assertAlmostEqual(cases.stream_share(1.8, 2.3), 0.9, places=14)  # caches: the loop passes 2
        row = {}
        cases.add_stream_share(row, 1.7, None)
        self.assertEqual(row, {"stream_speedup": "1.700", "thread_speedup_share": ""})
        cases.add_stream_share(row, 1.7, 1.36)
        self.assertEqual(row["thread_speedup_share"], "0.800")
        self.assertEqual(cases.stream_fields(row), {"stream_speedup": 1.7, "thread_speedup_share": 0.8})
        self.assertEqual(cases.stream_fields({"thread_speedup": "1.2"}), {})  # rows written before issue 63


class KeptScenes(unittest.TestCase):
    """`perf run --scenes`: rows kept from an earlier run keep that run's commit and load."""

    def test_scene_run(self):
        run = lambda commit, load: {"versions": {"sparkdem": commit}, "load_before": [load], "load_after": [load],
                                    "load_max": load, "finished": "t", "repeats": 5}
        meta = dict(run("new", 1.0), kept_runs={"pour": run("old", 0.5)})
        self.assertEqual(perf.scene_run(meta, "pour")["versions"]["sparkdem"], "old")
        self.assertEqual(perf.scene_run(meta, "poly_box_bed")["versions"]["sparkdem"], "new")
        self.assertEqual(perf.scene_run(meta, None)["load_max"], 1.0)

    def test_committed_mechanics_records(self):
        # The committed mechanics result: each record's commit is its own row's commit column.
        case = next(c for c in perf.case_table.CASES if c.id == "mechanics")
        path = perf.os.path.join(perf.REPO, case.result)
        rows = {f"perf/mechanics/{r['scene']}/{r['variant']}": r["commit"] for r in perf.case_table.rows_of(path)}
        for r in perf.records_of(case, path):
            self.assertTrue(r["commit"].startswith(rows[r["id"]]), (r["id"], r["commit"], rows[r["id"]]))


if __name__ == "__main__":
    unittest.main()
