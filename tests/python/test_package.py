#!/usr/bin/python3
"""The tribo Python package as a scientist meets it: one channel vocabulary
across CSV, descriptor and Python; a run folder read into numpy / pandas with
units; the run figure (200 dpi, legends beside the data, friction and µ);
`pip install` into a venv, offline, leaving the checkout as it was; the
example notebook executed on the venv's kernel, as docs/python.md says.

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
        self.assertEqual([l.get_label() for l in axes[0].get_lines()],
                         ["lateral force\n(+ towards +x)", "friction while sliding\n(against the motion)"])
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


class SixPassFigure(unittest.TestCase):
    """The run figure of a 6-pass velocity reversal (config/protocols/velocity_reversal.textproto)."""

    @classmethod
    def setUpClass(cls):
        from tribo_client import sim
        config = sim.load_config(os.path.join(ARGS.source_dir, "config/tribod.textproto"))
        cls.simulated = sim.simulate(config, os.path.join(ARGS.source_dir, "config/protocols/velocity_reversal.textproto"),
                               seed=1)
        cls.fig = plots.plot_run(cls.simulated, metrics=sim.metrics(cls.simulated))
        cls.fig.canvas.draw()
        cls.renderer = cls.fig.canvas.get_renderer()

    @classmethod
    def tearDownClass(cls):
        import matplotlib.pyplot as plt
        plt.close(cls.fig)

    def test_no_two_labels_overlap(self):
        for ax in self.fig.axes:
            texts = [t for t in ax.texts if t.get_visible() and t.get_text()]
            boxes = [t.get_window_extent(self.renderer) for t in texts]
            for i in range(len(boxes)):
                for j in range(i + 1, len(boxes)):
                    self.assertFalse(boxes[i].overlaps(boxes[j]),
                                     f"'{texts[i].get_text()}' overlaps '{texts[j].get_text()}'")
        segment_labels = [t.get_text() for t in self.fig.axes[0].texts if t.get_position()[1] > 1]
        self.assertEqual(len(segment_labels), 10, segment_labels)  # every segment named, shortened where needed
        self.assertIn("2: stroke", segment_labels)
        scratch_labels = [t.get_text() for t in self.fig.axes[1].texts]
        self.assertEqual(len(scratch_labels), 6, scratch_labels)  # the steady µ of every pass

    def test_friction_and_mu_are_not_negative_at_reversals(self):
        friction = plots.friction_n(self.simulated.samples)
        mu = plots.friction_coefficient(self.simulated.samples)
        self.assertGreater(np.count_nonzero(np.isfinite(friction)), len(friction) // 2)
        self.assertGreater(np.nanmin(friction), 0)
        self.assertGreater(np.nanmin(mu), 0)
        # The figure's friction and µ lines are those.
        for ax, label in ((self.fig.axes[0], "friction while sliding"), (self.fig.axes[1], "µ = friction")):
            line = next(l for l in ax.get_lines() if l.get_label().startswith(label))
            self.assertGreater(np.nanmin(line.get_ydata()), 0)

    def test_units_on_the_axes(self):
        self.assertEqual([ax.get_ylabel() for ax in self.fig.axes],
                         ["force (µN)", "friction coefficient µ", "normal force (µN)", "lateral position (µm)"])
        self.assertEqual(self.fig.axes[-1].get_xlabel(), "time (s)")


def tree_snapshot(root):
    """Every file and directory under root (but __pycache__, which other
    tests' imports write), with its modification time."""
    snapshot = {}
    for directory, subdirs, files in os.walk(root):
        subdirs[:] = [d for d in subdirs if d != "__pycache__"]
        for name in subdirs + files:
            path = os.path.join(directory, name)
            snapshot[os.path.relpath(path, root)] = os.stat(path).st_mtime_ns
    return snapshot


class VenvInstall(unittest.TestCase):
    """docs/python.md's commands, in order: the venv, `pip install
    client/python` offline from the checkout, the venv's Jupyter kernel, the
    example notebook executed on it. PYTHONPATH is unset throughout: the
    venv alone provides tribo_client, as for a user."""

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.venv = os.path.join(cls.tmp.name, "venv")
        cls.env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        cls.env["HOME"] = os.path.join(cls.tmp.name, "home")  # the kernel spec goes under ~/.local/share/jupyter
        cls.env["TRIBO_BUILD_DIR"] = ARGS.build_dir
        package = os.path.join(ARGS.source_dir, "client/python")
        cls.before = tree_snapshot(package)
        subprocess.run(["/usr/bin/python3", "-m", "venv", "--system-site-packages", cls.venv], check=True, timeout=120)
        cls.pip = subprocess.run([cls.bin("pip"), "install", "--no-build-isolation", "--no-index", package],
                                 capture_output=True, text=True, env=cls.env, cwd=ARGS.source_dir, timeout=300)
        cls.after = tree_snapshot(package)
        cls.env.pop("TRIBO_BUILD_DIR")

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    @classmethod
    def bin(cls, name):
        return os.path.join(cls.venv, "bin", name)

    def run_in(self, args, cwd, timeout=60):
        return subprocess.run(args, capture_output=True, text=True, env=self.env, cwd=cwd, timeout=timeout)

    def test_pip_installs_offline_and_leaves_the_checkout_as_it_was(self):
        self.assertEqual(self.pip.returncode, 0, self.pip.stdout[-2000:] + self.pip.stderr[-2000:])
        changed = sorted(p for p in set(self.before) | set(self.after) if self.before.get(p) != self.after.get(p))
        self.assertEqual(changed, [], "pip install wrote into client/python")
        check = ("import tribo_client, tribo_client.sim as sim, tribo_client.campaign;"
                 "from tribo.v1 import api_pb2;"
                 "print(tribo_client.__file__); print(sim.software_version)")
        result = self.run_in([self.bin("python"), "-c", check], self.tmp.name)
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assertIn(os.path.join(self.venv, "lib"), result.stdout)
        campaign = self.run_in([self.bin("tribo-campaign"), "--version"], self.tmp.name)
        self.assertEqual(campaign.returncode, 0, campaign.stderr)
        self.assertIn("tribo-campaign", campaign.stdout)

    def test_example_notebook_runs_on_the_venv_kernel(self):
        self.assertEqual(self.pip.returncode, 0, self.pip.stderr[-2000:])
        kernel = self.run_in([self.bin("python"), "-m", "ipykernel", "install", "--user", "--name", "tribo",
                              "--display-name", "Python (tribo)"], self.tmp.name)
        self.assertEqual(kernel.returncode, 0, kernel.stderr)
        # The docs' command, where it stands: it finds config/ in its checkout and writes scratch.png
        # beside itself (ignored by git; removed here).
        figure = os.path.join(ARGS.source_dir, "client/python/examples/scratch.png")
        existed = os.path.exists(figure)
        try:
            result = self.run_in(["jupyter-execute", "--kernel_name=tribo",
                                  "client/python/examples/simulated_scratch.ipynb"], ARGS.source_dir, timeout=240)
            self.assertEqual(result.returncode, 0, result.stderr[-3000:])
            self.assertEqual(png_dpi(figure), 200)
        finally:
            if not existed and os.path.exists(figure):
                os.remove(figure)
        # Elsewhere, pointed at the checkout; and the notebook's own kernel, the system interpreter,
        # cannot import the package: the kernel step is what makes the notebook run.
        work = os.path.join(self.tmp.name, "notebook")
        os.makedirs(work)
        notebook = shutil.copy(os.path.join(ARGS.source_dir, "client/python/examples/simulated_scratch.ipynb"), work)
        env = dict(self.env, TRIBO_SOURCE_DIR=ARGS.source_dir)
        result = subprocess.run(["jupyter-execute", "--kernel_name=tribo", notebook], capture_output=True, text=True,
                                env=env, cwd=work, timeout=240)
        self.assertEqual(result.returncode, 0, result.stderr[-3000:])
        self.assertEqual(png_dpi(os.path.join(work, "scratch.png")), 200)
        default = subprocess.run(["jupyter-execute", notebook], capture_output=True, text=True, env=env, cwd=work,
                                 timeout=240)
        self.assertNotEqual(default.returncode, 0)
        self.assertIn("No module named 'tribo_client'", default.stderr)


if __name__ == "__main__":
    support.main()
