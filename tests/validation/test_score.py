"""Checks of score.py's oracle column (--true-velocity): the generator's true velocity is added
to a written record as its last column, once, and a record whose length does not match the
generator's is an error. A stand-in generator keeps it fast (no family is simulated). And
servo_ipd's injected strengths in the analysis's parameters, from the generator's own truth
(its draws only, nothing simulated)."""

import math
import os
import sys
import tempfile
import unittest

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import score  # noqa: E402


class StandInGenerator:
    """run(effect, seed, traces=True) as a family's generate.py gives it, for three samples."""

    def __init__(self, velocity):
        self.velocity = np.asarray(velocity)
        self.calls = 0

    def run(self, effect, seed, traces=False):
        self.calls += 1
        return {}, {"v_true": self.velocity}


def write_record(path, rows):
    with open(path, "w") as f:
        f.write("t_s,x_m,x_ref_m,force_N,normal_N\n")
        for r in rows:
            f.write(",".join(f"{v:.6e}" for v in r) + "\n")


class TrueVelocityColumn(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.csv = os.path.join(self.dir.name, "family_none_seed1.csv")
        write_record(self.csv, [[0.0, 0.0, 0.0, 1e-5, 1e-3], [0.001, 1e-9, 2e-9, 2e-5, 1e-3],
                                [0.002, 3e-9, 4e-9, 3e-5, 1e-3]])

    def tearDown(self):
        self.dir.cleanup()

    def test_the_true_velocity_is_the_last_column_sample_by_sample(self):
        generator = StandInGenerator([0.0, 1.5e-6, -2.25e-6])
        score.add_true_velocity(generator, self.csv, "none", 1)
        with open(self.csv) as f:
            header = f.readline().strip().split(",")
        data = np.loadtxt(self.csv, delimiter=",", skiprows=1)
        self.assertEqual(header[-1], score.TRUE_VELOCITY_COLUMN)
        self.assertEqual(data.shape, (3, 6))
        np.testing.assert_allclose(data[:, -1], generator.velocity, rtol=1e-9, atol=0)
        np.testing.assert_allclose(data[:, 3], [1e-5, 2e-5, 3e-5], rtol=1e-6)

    def test_a_record_that_has_the_column_is_left_as_it_is(self):
        generator = StandInGenerator([0.0, 1e-6, 2e-6])
        score.add_true_velocity(generator, self.csv, "none", 1)
        with open(self.csv) as f:
            first = f.read()
        score.add_true_velocity(generator, self.csv, "none", 1)
        with open(self.csv) as f:
            self.assertEqual(f.read(), first)
        self.assertEqual(generator.calls, 1)

    def test_a_generator_of_another_length_is_an_error(self):
        with self.assertRaisesRegex(RuntimeError, "3 samples but 2 true velocities"):
            score.add_true_velocity(StandInGenerator([0.0, 1e-6]), self.csv, "none", 1)


class ServoIpdStrengthInTheAnalysisParameter(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.generator = score.load_module("tests/validation/families/servo_ipd/generate.py")

    def truth(self, effect, seed=3):
        b = self.generator.build(effect, seed)
        return self.generator.truth(effect, seed, b, {"substeps_per_tick": 1})

    def test_the_shared_forms_are_converted_from_the_truth(self):
        tilt = self.truth("tilt_offset")
        self.assertAlmostEqual(score.analysis_strength("tilt_offset", tilt), math.tan(math.radians(0.6)), places=12)
        for effect in ("frictional_lag", "direction_asymmetry", "backlash"):
            self.assertEqual(score.analysis_strength(effect, self.truth(effect)), self.generator.DEFAULT_STRENGTH[effect])
        vs = self.truth("velocity_strengthening")
        self.assertAlmostEqual(score.analysis_strength("velocity_strengthening", vs), 0.06 * vs["contact"]["mu_c"],
                               places=12)

    def test_the_drift_is_its_change_over_the_record(self):
        truth = self.truth("drift")
        duration = truth["protocol"]["duration_s"]
        tau = truth["effect_parameters"]["time_constant_s"]
        change = score.analysis_strength("drift", truth)
        # tau_d is 0.3-0.6 of the record: 81-96 % of the settled 60 uN.
        self.assertTrue(0.81 * 60e-6 < change < 0.97 * 60e-6, change)
        self.assertAlmostEqual(change, 60e-6 * (1 - math.exp(-duration / tau)), places=15)

    def test_the_forms_that_share_no_parameter_have_none(self):
        for effect in ("dwell_stiction", "load_dependence", "position_periodic", "presliding_hysteresis",
                       "rate_state"):
            self.assertIsNone(score.analysis_strength(effect, self.truth(effect)), effect)

    def test_a_tilt_miss_is_below_detection_only_under_the_reports_figure(self):
        injected = score.analysis_strength("tilt_offset", self.truth("tilt_offset"))
        report = {"rejected_effects": [{"name": "tilt_offset", "minimum_detectable": {"value": 2 * injected}}]}
        self.assertTrue(score.is_below_detection(False, injected, score.minimum_detectable(report, "tilt_offset")))
        report["rejected_effects"][0]["minimum_detectable"]["value"] = 0.5 * injected
        self.assertFalse(score.is_below_detection(False, injected, score.minimum_detectable(report, "tilt_offset")))
        # No figure up to the searched strength: below detection; a named effect never is.
        report["rejected_effects"][0]["minimum_detectable"]["value"] = None
        self.assertTrue(score.is_below_detection(False, injected, score.minimum_detectable(report, "tilt_offset")))
        self.assertFalse(score.is_below_detection(True, injected, math.inf))

    def test_a_miss_of_a_form_without_a_shared_parameter_counts(self):
        injected = score.analysis_strength("rate_state", self.truth("rate_state"))
        self.assertFalse(score.is_below_detection(False, injected, 1.0))
        withheld = {"rejected_effects": [{"name": "tilt_offset", "minimum_detectable": {"value": None, "withheld": "past bounds"}}]}
        self.assertFalse(score.is_below_detection(False, 0.01, score.minimum_detectable(withheld, "tilt_offset")))

if __name__ == "__main__":
    unittest.main()
