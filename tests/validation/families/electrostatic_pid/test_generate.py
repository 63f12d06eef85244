"""Checks of the electrostatic_pid generator: the data contract, determinism, the loop.

Run: /usr/bin/python3 -m unittest tests/validation/families/electrostatic_pid/test_generate.py
"""

import csv
import json
import math
import os
import sys
import tempfile
import unittest

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import generate as G  # noqa: E402

HEADER = ["t_s", "x_m", "x_ref_m", "force_N", "normal_N"]
TRUTH_KEYS = {"family", "effect", "in_vocabulary", "strength", "strength_unit", "seed",
              "rate_hz", "contact", "effect_parameters", "loop", "noise", "protocol"}
CONTACT_KEYS = {"mu_c", "mu_s", "vs_m_per_s", "stribeck_exponent", "sigma0_n_per_m",
                "sigma1_n_s_per_m", "fv_n_s_per_m"}


class TestContract(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.TemporaryDirectory()
        # seed 6 is a short record (about 60 s at 10 kHz); tilt changes the force at rest
        cls.csv1 = G.write(cls.dir.name, "tilt_offset", 6)
        with open(cls.csv1) as f:
            cls.text1 = f.read()
        with open(cls.csv1[:-4] + ".json") as f:
            cls.truth = json.load(f)
        other = os.path.join(cls.dir.name, "again")
        cls.csv2 = G.write(other, "tilt_offset", 6)
        with open(cls.csv2) as f:
            cls.text2 = f.read()

    @classmethod
    def tearDownClass(cls):
        cls.dir.cleanup()

    def test_file_names(self):
        self.assertEqual(os.path.basename(self.csv1), "electrostatic_pid_tilt_offset_seed6.csv")
        self.assertTrue(os.path.exists(self.csv1[:-4] + ".json"))

    def test_header_and_columns(self):
        rows = list(csv.reader(self.text1.splitlines()))
        self.assertEqual(rows[0], HEADER)
        data = np.array(rows[1:], dtype=float)
        self.assertEqual(data.shape[1], 5)
        self.assertTrue(np.all(np.isfinite(data)))
        dt = np.diff(data[:, 0])
        self.assertAlmostEqual(float(np.median(dt)), 1.0 / self.truth["rate_hz"], places=9)
        self.assertLess(np.max(np.abs(data[:, 1])), 20e-6)         # metres, not µm
        self.assertLess(np.max(data[:, 4]), 11e-3)                 # newtons, loads <= 10 mN
        self.assertGreater(np.max(data[:, 4]), 0.4e-3)

    def test_deterministic(self):
        self.assertEqual(self.text1, self.text2)

    def test_truth_keys(self):
        self.assertTrue(TRUTH_KEYS <= set(self.truth))
        self.assertEqual(set(self.truth["contact"]), CONTACT_KEYS)
        self.assertEqual(self.truth["family"], "electrostatic_pid")
        self.assertEqual(self.truth["effect"], "tilt_offset")
        self.assertTrue(self.truth["in_vocabulary"])
        self.assertEqual(self.truth["seed"], 6)
        self.assertEqual(self.truth["strength"], G.DEFAULT_STRENGTH["tilt_offset"])
        self.assertIn("duration_s", self.truth["protocol"])
        self.assertIn("description", self.truth["protocol"])
        c = self.truth["contact"]
        self.assertGreater(c["mu_s"], c["mu_c"])
        self.assertEqual(c["stribeck_exponent"], 1.0)

    def test_strength_option_changes_record_and_truth(self):
        path = G.write(os.path.join(self.dir.name, "s"), "tilt_offset", 6, strength=1.2)
        with open(path[:-4] + ".json") as f:
            truth = json.load(f)
        self.assertEqual(truth["strength"], 1.2)
        self.assertEqual(truth["effect_parameters"]["angle_deg"], 1.2 * math.copysign(
            1.0, self.truth["effect_parameters"]["angle_deg"]))
        with open(path) as f:
            self.assertNotEqual(f.read(), self.text1)

    def test_interface(self):
        self.assertEqual(G.EFFECTS[0], "none")
        self.assertEqual(set(G.EFFECTS), set(G.DEFAULT_STRENGTH))
        self.assertTrue(any(e.startswith("oov_") for e in G.EFFECTS))
        for name in ["dwell_stiction", "frictional_lag", "velocity_strengthening",
                     "load_dependence", "position_periodic", "direction_asymmetry",
                     "tilt_offset", "drift", "presliding_hysteresis", "backlash", "rate_state"]:
            self.assertIn(name, G.EFFECTS)
        with self.assertRaises(ValueError):
            G.make_record("no_such_effect", 1)


class TestLoop(unittest.TestCase):
    def test_drawn_loops_are_stable_with_margins(self):
        for seed in [1, 2, 3, 4, 5]:
            d = G.design(seed)
            loop, plant, contact = d["loop"], d["plant"], d["contact"]
            self.assertGreaterEqual(G.loop_damping(plant, loop, contact), G.MIN_LOOP_DAMPING)
            gm, pm = G.loop_robustness(plant, loop, contact)
            self.assertGreaterEqual(gm, G.MIN_GAIN_MARGIN)
            self.assertGreaterEqual(pm, G.MIN_PHASE_MARGIN_DEG)
            self.assertTrue(G.loop_acceptable(plant, loop, contact)[0])
            self.assertTrue(300 <= loop["kp_n_per_m"] <= 1500)
            self.assertTrue(1000 <= loop["ki_n_per_m_s"] <= 8000)

    def test_stability_check_rejects_a_loop_without_derivative_action(self):
        d = G.design(1)
        self.assertTrue(G.loop_acceptable(d["plant"], d["loop"], d["contact"])[0])
        loop = dict(d["loop"], kd_n_s_per_m=0.0, kp_n_per_m=1500.0)
        self.assertFalse(G.loop_acceptable(d["plant"], loop, d["contact"])[0])

    def test_records_follow_the_setpoint_without_divergence(self):
        for seed in [2, 6]:
            rec = G.make_record("none", seed)
            self.assertIsNone(rec["sim"]["diverged_at_tick"])
            err = rec["x_ref"] - rec["sim"]["x_true"]
            # a soft loop lags by up to a few µm, never by more than a stroke
            self.assertLess(np.max(np.abs(err)), 5e-6)
            self.assertGreater(np.max(np.abs(err)), 0.1e-6)


if __name__ == "__main__":
    unittest.main()
