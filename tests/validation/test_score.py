"""Checks of score.py's oracle column (--true-velocity): the generator's true velocity is added
to a written record as its last column, once, and a record whose length does not match the
generator's is an error. A stand-in generator keeps it fast (no family is simulated)."""

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


if __name__ == "__main__":
    unittest.main()
