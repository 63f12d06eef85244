"""Checks of the servo_ipd generator: determinism, the data contract, the loop's stability and
the readout floors. Runs with `python3 -m pytest` or `python3 -m unittest` from this folder or
with the path given (about a minute: each record takes a few seconds to simulate)."""

import csv
import json
import os
import sys
import tempfile
import unittest

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import generate as g  # noqa: E402

TRUTH_KEYS = {"family", "effect", "in_vocabulary", "strength", "strength_unit", "seed",
              "rate_hz", "contact", "effect_parameters", "loop", "noise", "protocol"}
CONTACT_KEYS = {"mu_c", "mu_s", "vs_m_per_s", "stribeck_exponent", "sigma0_n_per_m",
                "sigma1_n_s_per_m", "fv_n_s_per_m"}


def _holds(rec):
    """Sample intervals (as np.diff indexes them) during which the setpoint is held."""
    return np.diff(rec["x_ref"]) == 0.0


class Contract(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp()
        cls.csv1 = g.write(cls.dir, "tilt_offset", 7)
        with open(cls.csv1, "rb") as f:
            cls.bytes1 = f.read()

    def test_file_names(self):
        self.assertEqual(os.path.basename(self.csv1), "servo_ipd_tilt_offset_seed7.csv")
        self.assertTrue(os.path.exists(os.path.join(self.dir, "servo_ipd_tilt_offset_seed7.json")))

    def test_header_and_columns(self):
        with open(self.csv1) as f:
            rows = list(csv.reader(f))
        self.assertEqual(rows[0], ["t_s", "x_m", "x_ref_m", "force_N", "normal_N"])
        data = np.array(rows[1:], dtype=float)
        self.assertEqual(data.shape[1], 5)
        self.assertTrue(np.all(np.isfinite(data)))
        dt = np.diff(data[:, 0])
        with open(self.csv1[:-4] + ".json") as f:
            truth = json.load(f)
        self.assertAlmostEqual(float(np.median(dt)), 1.0 / truth["rate_hz"], places=9)
        self.assertTrue(np.all(data[:, 4] > 0.4e-3) and np.all(data[:, 4] < 10.1e-3))

    def test_truth_keys(self):
        with open(self.csv1[:-4] + ".json") as f:
            truth = json.load(f)
        self.assertTrue(TRUTH_KEYS <= set(truth), TRUTH_KEYS - set(truth))
        self.assertTrue(CONTACT_KEYS <= set(truth["contact"]))
        self.assertEqual(truth["family"], "servo_ipd")
        self.assertEqual(truth["effect"], "tilt_offset")
        self.assertTrue(truth["in_vocabulary"])
        self.assertEqual(truth["strength"], g.DEFAULT_STRENGTH["tilt_offset"])
        self.assertEqual(truth["seed"], 7)
        self.assertIn("duration_s", truth["protocol"])
        for k in ("kp_n_per_m", "ki_n_per_m_s", "kd_n_s_per_m", "mass_kg", "actuator_lag_s",
                  "spring_n_per_m", "controller_rate_hz"):
            self.assertIn(k, truth["loop"])

    def test_deterministic(self):
        d2 = tempfile.mkdtemp()
        csv2 = g.write(d2, "tilt_offset", 7)
        with open(csv2, "rb") as f:
            self.assertEqual(f.read(), self.bytes1)

    def test_strength_argument(self):
        d2 = tempfile.mkdtemp()
        csv2 = g.write(d2, "tilt_offset", 7, strength=1.5)
        with open(csv2[:-4] + ".json") as f:
            self.assertEqual(json.load(f)["strength"], 1.5)
        with open(csv2, "rb") as f:
            self.assertNotEqual(f.read(), self.bytes1)


class Module(unittest.TestCase):
    def test_effects_and_strengths(self):
        self.assertIn("none", g.EFFECTS)
        self.assertTrue(any(e.startswith("oov_") for e in g.EFFECTS))
        for e in ("dwell_stiction", "frictional_lag", "velocity_strengthening",
                  "load_dependence", "position_periodic", "direction_asymmetry", "tilt_offset",
                  "drift", "presliding_hysteresis", "backlash", "rate_state"):
            self.assertIn(e, g.EFFECTS)
        self.assertEqual(set(g.DEFAULT_STRENGTH), set(g.EFFECTS))

    def test_unknown_effect_rejected(self):
        with self.assertRaises(ValueError):
            g.build("wear", 1)

    def test_protocol_independent_of_effect(self):
        b0 = g.build("none", 3)
        b1 = g.build("backlash", 3)
        self.assertEqual(b0["loop"], b1["loop"])
        self.assertEqual(b0["contact"], b1["contact"])
        np.testing.assert_array_equal(b0["protocol"]["x_ref"], b1["protocol"]["x_ref"])

    def test_stability_check_detects_an_unstable_loop(self):
        # the criterion must be able to fail: a stiff loop (kp 1400 N/m) without derivative
        # action, a slow actuator and a slow controller oscillate even in contact
        b = g.build("none", 1)
        loop = dict(b["loop"], kp_n_per_m=1400.0, kd_n_s_per_m=0.0, actuator_lag_s=2e-3,
                    controller_rate_hz=2000.0)
        z_contact, _ = g.loop_damping(loop, b["contact"])
        self.assertLess(z_contact, 0.0)


class Loop(unittest.TestCase):
    """Seeds of the clean family: stable loop, the tip lags and follows, floors as stated."""

    @classmethod
    def setUpClass(cls):
        cls.runs = {s: g.run("none", s, traces=True) for s in (1, 2, 5)}

    def test_linearised_loop_damped(self):
        for s, (b, _) in self.runs.items():
            self.assertGreaterEqual(b["loop"]["min_mode_damping_ratio_in_contact"], 0.1, s)
            self.assertLessEqual(b["loop"]["loop_force_noise_n"], 8e-6, s)

    def test_loop_follows_setpoint(self):
        for s, (b, rec) in self.runs.items():
            err = rec["x_ref"] - rec["x_true"]
            self.assertLess(np.abs(err).max(), 8e-6, s)          # bounded: no divergence
            self.assertLess(np.abs(err[-100:]).max(), 0.2e-6, s)  # settled at the end
            nmax = rec["normal"].max()
            self.assertLess(np.abs(rec["force"]).max(), 2.0 * b["contact"]["mu_s"] * nmax, s)

    def test_tip_lags_while_sliding(self):
        # steady ramp lag (kp + ks) v0 / ki in the late part of strokes at >= 2 µm/s
        for s, (b, rec) in self.runs.items():
            vr = np.append(np.diff(rec["x_ref"]) / np.diff(rec["t"]), 0.0)
            lag = (rec["x_ref"] - rec["x_true"]) * np.sign(vr)
            fast = np.abs(vr) > 2e-6
            self.assertGreater(np.median(lag[fast]), 0.02e-6, s)

    def test_record_noise_at_floors(self):
        for s, (b, rec) in self.runs.items():
            h = _holds(rec)
            sx = np.std(np.diff(rec["x"])[h]) / np.sqrt(2.0)
            sf = np.std(np.diff(rec["force"])[h]) / np.sqrt(2.0)
            self.assertAlmostEqual(sx / 10e-9, 1.0, delta=0.15, msg=str(s))
            self.assertAlmostEqual(sf / 10e-6, 1.0, delta=0.2, msg=str(s))


if __name__ == "__main__":
    unittest.main()
