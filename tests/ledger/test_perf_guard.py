#!/usr/bin/python3
"""The perf guard of tools/perf.py (issue 40 item 6): a figure more than 10 % worse than the last
record of the same id is flagged, one within 10 % or better is not, and only time and memory units
(lower is better) are compared. ctest: perf/guard (label validation)."""
import unittest

from tools import perf


def rec(rid, value, unit="s", commit="0123456789ab"):
    return {"id": rid, "value": value, "unit": unit, "commit": commit}


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
