#!/usr/bin/python3
"""The validation ledger's rules (tools/ledger.py, tools/validate.py; benchmarks/validation/README.md):
a record from a dirty tree, a cleared tuned mark, a NaN and one run counted twice are each caught;
a rebase whose reason says the change was decided after seeing a figure is refused without --seen;
a rerun keeps every mark; only validation records pass. ctest: ledger/rules (label validation)."""
import argparse
import os
import stat
import tempfile
import types
import unittest

from tools import ledger as rules
from tools import validate

MARK = {"parameter": "configs/x.json#/strength", "why": "chosen after one run (test)"}


def write(path, text):
    with open(path, "w") as f:
        f.write(text)


def record(passed=True, **kw):
    """A sound full-tier validation record; passed: its `pass` field (a keyword in Python)."""
    r = {"case": "seed001/fig_a", "tier": "full", "N": 100, "kind": "validation", "commit": "0123456789ab",
         "clean": True, "run_file": "runs/full/x/N100.json", "measured": 1.0, "reference": 1.0, "error": 0.0,
         "per_seed": [{"seed": 1, "measured": 1.0}], "tuned_after_seeing": [], "pass": passed, "date": "2026-11-27"}
    r.update(kw)
    return r


class Rules(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp()
        os.makedirs(os.path.join(self.dir, "runs", "full", "x"))
        write(os.path.join(self.dir, "runs", "full", "x", "N100.json"), "{}")

    def check(self, ledger, head=None):
        return rules.check_rules(ledger, head, self.dir)

    def test_sound_ledger_passes(self):
        self.assertEqual(self.check({"records": [record()]}), [])

    def test_dirty_record_fails_unless_provisional_or_legacy(self):
        for dirty in (record(commit="0123456789ab+dirty"), record(clean=False)):
            self.assertTrue(any("dirty" in b for b in self.check({"records": [dirty]})))
        self.assertEqual(self.check({"records": [record(clean=False, provisional=True, passed=False)]}), [])
        self.assertEqual(self.check({"records": [record(commit="0123+dirty", legacy="old", run_file=None)]}), [])

    def test_cleared_mark_fails(self):
        ledger = {"records": [record(passed=False)], "tuned_marks": {"seed001/fig_a": [MARK]}}
        self.assertTrue(any("cleared" in b for b in self.check(ledger)))
        head = {"tuned_marks": {"seed001/fig_a": [MARK]}}
        self.assertTrue(any("gone" in b for b in self.check({"records": [record()]}, head)))
        ok = {"records": [record(tuned_after_seeing=[MARK], passed=False)], "tuned_marks": {"seed001/fig_a": [MARK]}}
        self.assertEqual([b for b in self.check(ok) if "cleared" in b or "gone" in b], [])

    def test_tuned_record_never_passes(self):
        bad = self.check({"records": [record(tuned_after_seeing=[MARK], passed=True)]})
        self.assertTrue(any("passes although tuned" in b for b in bad))

    def test_nan_is_refused_and_written_as_null(self):
        path = os.path.join(self.dir, "l.json")
        write(path, '{"records": [{"measured": NaN}]}')
        with self.assertRaises(ValueError):
            rules.load_strict(path)
        rules.write_json_atomic(path, {"x": float("nan"), "y": [1.0, float("inf")]})
        self.assertEqual(rules.load_strict(path), {"x": None, "y": [1.0, None]})

    def test_one_run_counted_twice_fails(self):
        a, b = record(), record(case="seed001/fig_b")
        self.assertTrue(any("counted twice" in x for x in self.check({"records": [a, b]})))
        b["per_seed"] = [{"seed": 1, "measured": 2.0}]
        self.assertEqual(self.check({"records": [a, b]}), [])

    def test_one_value_against_two_references_or_a_declared_pair_passes(self):
        a = record(per_seed=[{"seed": 1, "measured": 1.0, "reference": 1.0}], band=0.05)
        b = record(case="seed001/fig_b", per_seed=[{"seed": 1, "measured": 1.0, "reference": 1.1}], band=0.05)
        self.assertEqual(self.check({"records": [a, b]}), [])  # two references: two comparisons
        b["per_seed"][0]["reference"] = 1.0
        self.assertTrue(any("counted twice" in x for x in self.check({"records": [a, b]})))
        b["band"] = 0.092  # a reproduce band beside a tighter one
        self.assertEqual(self.check({"records": [a, b]}), [])
        b["band"] = 0.05
        b["shares_values_with"] = ["seed001/fig_a"]  # equal by design (a detector that fires at the break)
        self.assertEqual(self.check({"records": [a, b]}), [])

    def test_only_validation_records_pass(self):
        for kind in ("calibration", "construction", "regression"):
            bad = self.check({"records": [record(kind=kind)]})
            self.assertTrue(any("carries pass" in b for b in bad), kind)
        self.assertEqual(rules.verdict(record(kind="regression", passed=False, inside_band=True)), "inside band")
        self.assertEqual(rules.verdict(record(kind="construction")), "by construction")

    def test_reason_that_says_seen(self):
        self.assertTrue(rules.reason_says_seen("Decided after one N = 2500 pin run with the tension strength"))
        self.assertTrue(rules.reason_says_seen("chosen after seeing the densification"))
        self.assertFalse(rules.reason_says_seen("issue 21 item 3: Eq. 28 as written, decided from the paper's text "
                                                "before these runs"))

    def test_rebase_refuses_a_seen_reason_without_flag(self):
        a = argparse.Namespace(why="decided after one N = 2500 run", seen=False, ledger="/nonexistent", case=["x"])
        self.assertEqual(validate.cmd_rebase(a), 2)

    def test_rerun_keeps_marks(self):
        ledger = {"records": [record(tuned_after_seeing=[MARK], passed=False)]}
        validate.store(ledger, record())  # a rerun whose record came without the mark
        self.assertEqual(ledger["records"][0]["tuned_after_seeing"], [MARK])
        self.assertFalse(ledger["records"][0]["pass"])
        self.assertEqual(self.check(ledger), [])

    def test_dirty_binary_refused(self):
        runner = types.SimpleNamespace(clean=False, commit="0123456789ab")
        a = argparse.Namespace(no_record=False, provisional=False, sparkdem="sparkdem")
        self.assertIn("refusing to record", validate.refuse_dirty(runner, a))
        self.assertIsNone(validate.refuse_dirty(runner, argparse.Namespace(no_record=False, provisional=True,
                                                                           sparkdem="s")))

    def test_version_parsed(self):
        fake = os.path.join(self.dir, "fake_sparkdem")
        for text, want in (("sparkdem 0.1.0, commit 0123456789abcdef (dirty work tree)", ("0123456789ab", False)),
                           ("sparkdem 0.1.0, commit 0123456789abcdef (clean)", ("0123456789ab", True)),
                           ("sparkdem 0.1.0", ("unknown", False))):
            write(fake, f"#!/bin/sh\necho '{text}'\n")
            os.chmod(fake, stat.S_IRWXU)
            self.assertEqual(rules.binary_build(fake), want)


if __name__ == "__main__":
    unittest.main()
