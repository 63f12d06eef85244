#!/usr/bin/python3
"""The Python client against a real tribod: run a protocol into numpy arrays,
compare with the daemon's recording, refuse observers' control commands, fetch
a recorded run, and plot a run to PNG with the example.

    /usr/bin/python3 tests/python/test_client.py --build-dir build --source-dir .
(PYTHONPATH must hold client/python and build/python.)"""

import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np

import support
from support import ARGS, Daemon, short_protocol
from tribo_client import Client, TriboError


class PythonClientTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.data = os.path.join(cls.tmp.name, "runs")
        cls.daemon = Daemon(cls.data)

    @classmethod
    def tearDownClass(cls):
        cls.daemon.stop()
        cls.tmp.cleanup()

    def test_run_streams_into_numpy_arrays_equal_to_the_recording(self):
        with Client(self.daemon.address, role="controller") as c:
            self.assertEqual(c.hello.role, "CONTROLLER")
            run = c.run(short_protocol(), seed=3)
        self.assertEqual(run.exit_status, "SUCCESS")
        n = run.stop.sample_count
        self.assertEqual(n, 3000)
        np.testing.assert_array_equal(run.sequence, np.arange(n))
        self.assertEqual([ch.name for ch in run.descriptor.channels][:2], ["t", "segment"])
        self.assertEqual([e.segment_index for e in run.segment_events], [0, 1, 2, 3, 4])
        csv = np.loadtxt(os.path.join(self.data, run.run_id, "samples.csv"), delimiter=",", skiprows=1)
        self.assertEqual(csv.shape, (n, 9))
        np.testing.assert_array_equal(run.samples["t"], csv[:, 0])
        np.testing.assert_array_equal(run.samples["lateral_force"], csv[:, 7])
        np.testing.assert_array_equal(run.samples["segment"], csv[:, 1].astype(np.uint32))

        with Client(self.daemon.address) as observer:
            fetched = observer.fetch(run.run_id)
            np.testing.assert_array_equal(fetched.samples["normal_force"], run.samples["normal_force"])
            self.assertEqual(fetched.exit_status, "SUCCESS")  # was None: fetch() left out the stop document
            self.assertEqual(fetched.segment_names, run.segment_names)
            self.assertIn(run.run_id, [r.run_id for r in observer.list_runs()])

    def test_set_gains_changes_only_the_given_gain(self):
        with Client(self.daemon.address, role="controller") as c:
            before = c.get_gains()
            self.assertEqual(len(before), 4)
            original_ki = before["lateral-force"].ki
            reply = c.set_gains("lateral-force", ki=original_ki + 100)
            self.assertEqual(reply.gains.ki, original_ki + 100)
            after = c.get_gains()
            expected = before["lateral-force"]
            expected.ki = original_ki + 100
            self.assertEqual(after["lateral-force"], expected)
            for name in ("lateral-displacement", "normal-force", "normal-displacement"):
                self.assertEqual(after[name], before[name])
            with self.assertRaises(TriboError) as caught:
                c.set_gains("lateral-force", kp=-1)
            self.assertEqual(caught.exception.code, "INVALID_ARGUMENT")
            self.assertIn("kp", caught.exception.field)
            with self.assertRaises(ValueError):
                c.set_gains("sideways", kp=1)
            c.set_gains("lateral-force", ki=original_ki)

    def test_observers_cannot_control(self):
        with Client(self.daemon.address) as observer:
            with self.assertRaises(TriboError) as caught:
                observer.start_run()
            self.assertEqual(caught.exception.code, "PERMISSION_DENIED")
            self.assertEqual(caught.exception.field, "role")
            status = observer.status()
            self.assertEqual(status.backend_health.backend, "sim")
            self.assertIn(status.state, ("IDLE", "ARMED"))  # a name, not the enum's number

    def test_example_plots_a_run_to_png(self):
        png = os.path.join(self.tmp.name, "run.png")
        protocol = os.path.join(self.tmp.name, "short.textproto")
        from google.protobuf import text_format
        with open(protocol, "w", encoding="utf-8") as f:
            f.write(text_format.MessageToString(short_protocol()))
        result = subprocess.run(
            [sys.executable, os.path.join(ARGS.source_dir, "client/python/examples/plot_run.py"),
             protocol, png, "--address", self.daemon.address],
            capture_output=True, text=True, timeout=120, env=os.environ)
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assertIn("SUCCESS", result.stdout)
        with open(png, "rb") as f:
            self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")
        self.assertGreater(os.path.getsize(png), 10000)


if __name__ == "__main__":
    support.main()
