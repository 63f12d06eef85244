#!/usr/bin/python3
"""The tribo Python package as a scientist meets it: one channel vocabulary
across CSV, descriptor and Python; a run folder read into numpy / pandas with
units; the run figure (200 dpi, legends beside the data, friction and µ);
the example notebook executed; `pip install` into a venv, offline.

    /usr/bin/python3 tests/python/test_package.py --build-dir build --source-dir .
(PYTHONPATH must hold client/python and build/python.)"""

import os
import shutil
import struct
import subprocess
import sys
import tempfile
import unittest

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import support
from support import ARGS, Daemon, short_protocol  # noqa: E402

from tribo_client import CHANNELS, Client, csv_column, plots, read_run  # noqa: E402


def png_dpi(path):
    """The PNG's pHYs resolution in dots per inch (None without the chunk)."""
    with open(path, "rb") as f:
        data = f.read()
    at = data.find(b"pHYs")
    if at < 0:
        return None
    x, _, unit = struct.unpack(">IIB", data[at + 4:at + 13])
    return round(x * 0.0254) if unit == 1 else None


class RunFolder(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        data = os.path.join(cls.tmp.name, "runs")
        cls.daemon = Daemon(data)
        with Client(cls.daemon.address, role="controller") as c:
            cls.streamed = c.run(short_protocol(), seed=5)
            cls.status = c.status()
        cls.run_dir = os.path.join(data, cls.streamed.run_id)

    @classmethod
    def tearDownClass(cls):
        cls.daemon.stop()
        cls.tmp.cleanup()

    def test_status_state_is_a_name(self):
        self.assertEqual(self.status.state, "ARMED")  # was 2
        self.assertEqual(self.status["state"], "ARMED")

    def test_one_channel_vocabulary(self):
        with open(os.path.join(self.run_dir, "samples.csv"), encoding="ascii") as f:
            header = f.readline().strip().split(",")
        self.assertEqual(header, [csv_column(c.name) for c in CHANNELS])
        self.assertIn("lateral_force_N", header)
        descriptor = [(ch.name, ch.unit) for ch in self.streamed.descriptor.channels]
        self.assertEqual(descriptor, [(c.name, c.unit) for c in CHANNELS])
        self.assertEqual(list(self.streamed.samples), [c.name for c in CHANNELS])

    def test_read_run_gives_arrays_units_and_documents(self):
        run = read_run(self.run_dir)
        self.assertEqual(run.exit_status, "SUCCESS")
        self.assertEqual(run.seed, 5)
        self.assertEqual(run.units["lateral_force"], "N")
        self.assertEqual(run.units["lateral_position"], "m")
        self.assertEqual(len(run), 3000)
        for c in CHANNELS:
            np.testing.assert_array_equal(run.samples[c.name], self.streamed.samples[c.name], err_msg=c.name)
        self.assertEqual(run.samples["segment"].dtype, np.uint32)
        df = run.to_dataframe()
        self.assertEqual(df.attrs["units"]["normal_force"], "N")
        self.assertEqual(list(df["segment_name"].cat.categories)[:1], ["approach"])
        self.assertEqual(run.segment_names, self.streamed.segment_names)

    def test_torn_last_row_is_dropped(self):
        torn = os.path.join(self.tmp.name, "torn")
        shutil.copytree(self.run_dir, torn)
        with open(os.path.join(torn, "samples.csv"), "ab") as f:
            f.write(b"3.001,4,0.00")  # a crash mid-row
        self.assertEqual(len(read_run(torn)), 3000)

    def test_run_figure_for_a_notebook(self):
        png = os.path.join(self.tmp.name, "run.png")
        fig = plots.plot_run(read_run(self.run_dir), png)
        self.assertEqual(png_dpi(png), 200)
        axes = fig.axes
        labels = [ax.get_ylabel() for ax in axes]
        self.assertEqual(labels, ["force (µN)", "friction coefficient µ", "normal force (µN)",
                                  "lateral position (µm)"])
        # Nothing but lateral forces on the force axis (no scaled normal force).
        self.assertEqual([l.get_label() for l in axes[0].get_lines()], ["lateral force (signed)", "friction (sliding)"])
        # Every legend lies beside its axes, not over the data.
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        for ax in axes:
            legend = ax.get_legend().get_window_extent(renderer)
            self.assertGreaterEqual(legend.x0, ax.get_window_extent(renderer).x1)
        # Segments named on the figure.
        texts = [t.get_text() for t in axes[0].texts]
        self.assertIn("2: scratch", " ".join(texts))
        # Friction on the sliding segment: positive, µ near the configured Coulomb coefficient.
        mu = plots.friction_coefficient(read_run(self.run_dir).samples)
        steady = np.nanmedian(mu)
        self.assertGreater(steady, 0.05)
        self.assertLess(steady, 0.2)


class Notebook(unittest.TestCase):
    def test_example_notebook_executes(self):
        with tempfile.TemporaryDirectory() as tmp:
            notebook = os.path.join(tmp, "simulated_scratch.ipynb")
            shutil.copy(os.path.join(ARGS.source_dir, "client/python/examples/simulated_scratch.ipynb"), notebook)
            env = dict(os.environ, TRIBO_SOURCE_DIR=ARGS.source_dir)
            env["PYTHONPATH"] = os.pathsep.join(os.path.abspath(p) for p in env.get("PYTHONPATH", "").split(os.pathsep) if p)
            result = subprocess.run([sys.executable, "-m", "nbconvert", "--to", "notebook", "--execute",
                                     "--ExecutePreprocessor.timeout=120", "--output", "executed.ipynb", notebook],
                                    capture_output=True, text=True, env=env, cwd=tmp, timeout=240)
            self.assertEqual(result.returncode, 0, result.stderr[-3000:])
            self.assertEqual(png_dpi(os.path.join(tmp, "scratch.png")), 200)


class PipInstall(unittest.TestCase):
    def test_pip_installs_offline_into_a_venv(self):
        with tempfile.TemporaryDirectory() as tmp:
            venv = os.path.join(tmp, "venv")
            subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", venv], check=True, timeout=120)
            package = os.path.join(tmp, "src")  # a copy: an in-tree build writes build/ and *.egg-info
            shutil.copytree(os.path.join(ARGS.source_dir, "client/python"), package,
                            ignore=shutil.ignore_patterns("__pycache__"))
            env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
            env["TRIBO_BUILD_DIR"] = ARGS.build_dir
            pip = subprocess.run([os.path.join(venv, "bin", "pip"), "install", "--no-build-isolation", "--no-index",
                                  package], capture_output=True, text=True, env=env, timeout=300)
            self.assertEqual(pip.returncode, 0, pip.stdout[-2000:] + pip.stderr[-2000:])
            check = ("import tribo_client, tribo_client.sim as sim, tribo_client.campaign;"
                     "from tribo.v1 import api_pb2;"
                     "print(tribo_client.__file__); print(sim.software_version)")
            env.pop("TRIBO_BUILD_DIR")
            result = subprocess.run([os.path.join(venv, "bin", "python"), "-c", check], capture_output=True,
                                    text=True, env=env, cwd=tmp, timeout=60)
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertIn(os.path.join(venv, "lib"), result.stdout)
            campaign = subprocess.run([os.path.join(venv, "bin", "tribo-campaign"), "--version"],
                                      capture_output=True, text=True, env=env, cwd=tmp, timeout=60)
            self.assertEqual(campaign.returncode, 0, campaign.stderr)
            self.assertIn("tribo-campaign", campaign.stdout)


if __name__ == "__main__":
    support.main()
