#!/usr/bin/python3
"""analysis/plot_diagnosis.py's signature figures: the residual's unit on the
axis (the input's force unit, squared for a power), points in markers sorted
along x (never joined in record order), a spectrum as a curve; on a real
diagnosis (tribo-fit diagnose --out) of the EMPS record.

    /usr/bin/python3 tests/python/test_plot_diagnosis.py --build-dir build --source-dir .
(PYTHONPATH must hold client/python and build/python.)"""

import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import support
from support import ARGS  # noqa: E402


def plot_diagnosis():
    spec = importlib.util.spec_from_file_location("plot_diagnosis",
                                                  os.path.join(ARGS.source_dir, "analysis/plot_diagnosis.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def ylabel(fig):
    return fig.axes[0].get_ylabel().replace("\n", " ")  # long labels are wrapped


def plotted(fig):
    """(x, y, linestyle, marker) of the figure's data line (not the zero line)."""
    ax = fig.axes[0]
    line = next(l for l in ax.get_lines() if len(l.get_xdata()) > 2)
    return np.asarray(line.get_xdata()), np.asarray(line.get_ydata()), line.get_linestyle(), line.get_marker()


class SignatureFigures(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.module = plot_diagnosis()
        cls.tmp = tempfile.TemporaryDirectory()
        out = os.path.join(cls.tmp.name, "emps")
        data = os.path.join(ARGS.source_dir, "tests/data/measured/emps_train_DATA_EMPS.csv")
        subprocess.run([ARGS.tribo_fit, "diagnose", data, "--time", "t_s", "--position", "x_m", "--motor-force",
                        "force_motor_N", "--velocity", "v_derived_m_s", "--acceleration", "a_derived_m_s2",
                        "--effects", "direction_asymmetry,position_periodic", "--out", out],
                       check=True, capture_output=True, timeout=600)
        with open(os.path.join(out, "diagnosis.json"), encoding="utf-8") as f:
            cls.report = json.load(f)
        cls.groups = cls.module.read_signatures(os.path.join(out, "signatures.csv"))

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def figure(self, effect):
        key = next(k for k in self.groups if k[0] == effect)
        return self.module.signature_figure(effect, key[1], self.groups[key], self.report["input"]["force_unit"], "")

    def test_residual_in_newtons_in_markers_along_velocity(self):
        fig = self.figure("direction_asymmetry")
        self.assertEqual(ylabel(fig), "residual (not direction-signed) (N)")
        self.assertEqual(fig.axes[0].get_xlabel(), "velocity (m/s)")
        x, _, linestyle, marker = plotted(fig)
        self.assertEqual(linestyle, "None")  # points, not joined
        self.assertEqual(marker, "o")
        self.assertTrue(np.all(np.diff(x) >= 0))

    def test_spectrum_in_newtons_squared_as_a_curve(self):
        fig = self.figure("position_periodic")
        self.assertEqual(ylabel(fig), "residual power against position (N²)")
        self.assertEqual(fig.axes[0].get_xlabel(), "wavelength (mm)")
        x, _, linestyle, _ = plotted(fig)
        self.assertEqual(linestyle, "-")
        self.assertTrue(np.all(np.diff(x) > 0))

    def test_points_given_in_record_order_are_drawn_sorted(self):
        # Per-pass points come in record order: plateau speeds up and down.
        group = {"x_label": "plateau speed (m/s)", "y_label": "mean direction-signed residual / level factor, per pass",
                 "x": [2e-6, 8e-6, 2e-6, 8e-6, 4e-6], "y": [1e-6, 3e-6, 2e-6, 4e-6, 5e-6], "e": [np.nan] * 5}
        fig = self.module.signature_figure("velocity_strengthening", "rejected", group, "N", "")
        x, y, linestyle, _ = plotted(fig)
        np.testing.assert_array_equal(x, [2e-6, 2e-6, 4e-6, 8e-6, 8e-6])
        np.testing.assert_allclose(y, [1, 2, 5, 3, 4])  # in µN, each with its x
        self.assertEqual(linestyle, "None")
        self.assertEqual(ylabel(fig), "mean direction-signed residual / level factor, per pass (µN)")

    def test_a_stress_keeps_its_unit(self):
        group = {"x_label": "slip since the speed step (m)", "y_label": "direction-signed residual / level factor",
                 "x": [1e-5, 2e-5, 3e-5], "y": [2e4, -1e4, 5e3], "e": [1e3, 1e3, 1e3]}
        fig = self.module.signature_figure("rate_state", "rejected", group, "Pa", "")
        self.assertEqual(ylabel(fig), "direction-signed residual / level factor (kPa)")
        self.assertEqual(fig.axes[0].get_xlabel(), "slip since the speed step (µm)")


if __name__ == "__main__":
    support.main()
