#!/usr/bin/python3
"""tribo_native / tribo_client.sim against the real tools: a run simulated
in-process equals tribod's recording byte for byte; metrics and diagnosis
equal tribo-fit's JSON; validation errors name the field; the GIL is
released while C++ runs.

    /usr/bin/python3 tests/python/test_native.py --build-dir build --source-dir .
(PYTHONPATH must hold client/python and build/python.)"""

import json
import os
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import numpy as np
from google.protobuf import text_format

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import support
from support import ARGS, Daemon, identification_short, short_protocol  # noqa: E402

import tribo_native  # noqa: E402
from tribo_client import Client, read_run, sim  # noqa: E402


class SimulatedRunEqualsTribod(unittest.TestCase):
    """A 19 s identification run (repeat blocks, per-pass values, 200 Hz) with
    the identification config, on tribod and in-process."""

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.data = os.path.join(cls.tmp.name, "runs")
        cls.config = sim.load_config(os.path.join(ARGS.source_dir, "config/tribod.textproto"))
        cls.config.controller.lateral_displacement.setpoint_weight_p = 1.0
        cls.config.sim.tip.tilt_offset.enabled = False
        config_path = os.path.join(cls.tmp.name, "tribod.textproto")
        with open(config_path, "w", encoding="utf-8") as f:
            f.write(text_format.MessageToString(cls.config))
        cls.protocol = identification_short()
        daemon = Daemon(cls.data, config_path)
        try:
            with Client(daemon.address, role="controller") as c:
                cls.recorded = c.run(cls.protocol, seed=7)
        finally:
            daemon.stop()
        cls.run_dir = os.path.join(cls.data, cls.recorded.run_id)
        cls.simulated = sim.simulate(cls.config, cls.protocol, seed=7)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_samples_csv_is_byte_for_byte_tribods(self):
        self.assertEqual(self.simulated.exit_status, "SUCCESS")
        with open(os.path.join(self.run_dir, "samples.csv"), "rb") as f:
            recorded = f.read()
        self.assertGreater(len(recorded), 300000)
        self.assertEqual(tribo_native.samples_csv(self.simulated.samples), recorded)

    def test_arrays_equal_the_run_folder_read_back(self):
        folder = read_run(self.run_dir)
        for name, values in folder.samples.items():
            np.testing.assert_array_equal(self.simulated.samples[name], values, err_msg=name)
            self.assertEqual(self.simulated.samples[name].dtype, values.dtype, name)

    def test_another_seed_differs(self):
        other = sim.simulate(self.config, self.protocol, seed=8)
        self.assertFalse(np.array_equal(other.samples["lateral_force"], self.simulated.samples["lateral_force"]))

    def test_metrics_equal_tribo_fit_metrics_json(self):
        cli = subprocess.run([ARGS.tribo_fit, "metrics", self.run_dir, "--json"], capture_output=True, text=True,
                             check=True)
        expected = json.loads(cli.stdout)
        self.assertTrue(expected["scratches"])
        self.assertEqual(sim.metrics(self.simulated), expected)
        self.assertEqual(sim.metrics(self.run_dir), expected)

    def test_diagnosis_equals_tribo_fit_diagnose_json(self):
        effects = "tilt_offset,direction_asymmetry"
        cli = subprocess.run([ARGS.tribo_fit, "diagnose", self.run_dir, "--json", "--effects", effects],
                             capture_output=True, text=True, check=True)
        expected = json.loads(cli.stdout)
        got = sim.diagnose(self.run_dir, effects=effects.split(","))
        for report in (expected, got):  # how and how long it ran, not what it found
            del report["input"]["command"]
            report.pop("elapsed_s", None)
        self.assertEqual(got, expected)
        self.assertIn("accepted_effects", got)
        # On the arrays of the simulated run: the same report, but for the source name.
        from_arrays = sim.diagnose(self.simulated, effects=effects.split(","))
        del from_arrays["input"]["command"], from_arrays["input"]["source"], expected["input"]["source"]
        from_arrays.pop("elapsed_s", None)
        self.assertEqual(from_arrays, expected)

    def test_contact_choice_equals_tribo_fit_base_model_choose(self):
        effects = "tilt_offset"
        cli = subprocess.run([ARGS.tribo_fit, "diagnose", self.run_dir, "--json", "--effects", effects,
                              "--base-model", "choose"], capture_output=True, text=True, check=True)
        expected = json.loads(cli.stdout)
        got = sim.diagnose(self.run_dir, effects=[effects], base_model="choose")
        for report in (expected, got):
            del report["input"]["command"]
            report.pop("elapsed_s", None)
        self.assertEqual(got, expected)
        self.assertEqual(got["base_model"]["contact_choice"]["options"][0]["name"], "lugre")
        with self.assertRaises(ValueError):
            sim.diagnose(self.run_dir, effects=[effects], base_model="maxwell")


class Validation(unittest.TestCase):
    def test_protocol_error_names_the_field(self):
        protocol = short_protocol()
        protocol.segments[1].normal.end_uN = 50000  # 50 mN, beyond the 10 mN limit
        with self.assertRaises(sim.ValidationError) as caught:
            sim.check(sim.load_config(os.path.join(ARGS.source_dir, "config/tribod.textproto")), protocol)
        self.assertEqual(caught.exception.field, "segments[1].normal.end_uN")
        self.assertIn("outside the normal force range [0, 10000] µN", caught.exception.message)

    def test_config_error_names_the_field(self):
        with open(os.path.join(ARGS.source_dir, "config/tribod.textproto"), encoding="utf-8") as f:
            text = f.read()
        config = sim.load_config(text)
        config.controller.loop_rate_hz = -5
        with self.assertRaises(sim.ValidationError) as caught:
            sim.load_config(config)
        self.assertIn("controller.loop_rate_hz", caught.exception.field)

    def test_dict_protocol_and_text_config(self):
        from google.protobuf import json_format
        as_dict = json_format.MessageToDict(short_protocol(), preserving_proto_field_name=True)
        summary = sim.check(os.path.join(ARGS.source_dir, "config/tribod.textproto"), as_dict)
        self.assertAlmostEqual(summary["duration_s"], 3.0)
        self.assertEqual(summary["expected_samples"], 3000)


class GilReleased(unittest.TestCase):
    def test_python_runs_while_the_simulation_does(self):
        config = sim.load_config(os.path.join(ARGS.source_dir, "config/tribod.textproto")).SerializeToString()
        protocol = sim.load_protocol(os.path.join(ARGS.source_dir, "config/protocols/standard_scratch.textproto"))
        protocol = protocol.SerializeToString()
        counter, during, done = [0], [], threading.Event()

        def simulate():
            before = counter[0]
            tribo_native.simulate(config, protocol, 1)
            during.append(counter[0] - before)
            done.set()

        thread = threading.Thread(target=simulate)
        thread.start()
        while not done.is_set():
            counter[0] += 1
            time.sleep(0)  # lets the other thread take the GIL whenever it wants it
        thread.join()
        # Had the run held the GIL, this loop could not have advanced during it (0).
        self.assertGreater(during[0], 100)


class FrictionCompensation(unittest.TestCase):
    """docs/friction_compensation.md from Python: a report compensates the
    run, the run says which one, and a report the compensation cannot
    represent is refused naming the field."""

    def setUp(self):
        self.report = os.path.join(ARGS.source_dir, "tests/data/friction_reports/identification.json")
        self.protocol = os.path.join(ARGS.source_dir, "config/protocols/standard_scratch.textproto")

    def test_simulate_with_a_friction_model_compensates_and_records_it(self):
        config = sim.load_config(os.path.join(ARGS.source_dir, "config/tribod.textproto"))
        without = sim.simulate(config, self.protocol, seed=1)
        run = sim.simulate(config, self.protocol, seed=1, friction_model=self.report)
        self.assertEqual(run.exit_status, "SUCCESS")
        self.assertTrue(np.all(run.samples["flags"] & 1024), "every sample carries FRICTION_COMPENSATED")
        self.assertFalse(np.any(without.samples["flags"] & 1024))
        model = run.metadata["start"]["friction_models"][0]
        # sha256sum tests/data/friction_reports/identification.json
        self.assertEqual(model["report_sha256"], "8e97474e04076d74d1d9601fbd005e21276ec9f28ec6427ff41f64d99bba46bf")
        self.assertEqual(model["contact"], "lugre + tilt_offset")
        with open(self.report, encoding="utf-8") as f:
            reported = {p["name"]: p["value"] for p in json.load(f)["final_model"]["parameters"]}
        self.assertEqual({p["name"]: p["value"] for p in model["parameters"]}, reported)
        # The drive changed, the friction read in steady sliding did not (its noise: 0.036 µN).
        window = (run.samples["t"] >= 16) & (run.samples["t"] < 24)
        self.assertFalse(np.array_equal(run.samples["lateral_position"], without.samples["lateral_position"]))
        self.assertAlmostEqual(run.samples["lateral_force"][window].mean() * 1e6,
                               without.samples["lateral_force"][window].mean() * 1e6, delta=0.036)

    def test_a_protocol_file_names_its_report_relative_to_itself(self):
        with tempfile.TemporaryDirectory() as tmp:
            with open(self.protocol, encoding="utf-8") as f:
                text = f.read()
            path = os.path.join(tmp, "scratch.textproto")
            with open(path, "w", encoding="utf-8") as f:
                f.write(text + '\nfriction_compensation { report_file: "model.json" }\n')
            with open(self.report, encoding="utf-8") as f, open(os.path.join(tmp, "model.json"), "w") as g:
                g.write(f.read())
            checked = sim.check(sim.load_config(os.path.join(ARGS.source_dir, "config/tribod.textproto")),
                                sim.load_protocol(path))
            self.assertEqual(checked["friction_models"][0]["report_file"], "model.json")
            self.assertEqual(checked["friction_models"][0]["segments"], [0, 1, 2, 3, 4])

    def test_a_model_it_cannot_represent_is_refused_naming_the_field(self):
        with open(self.report, encoding="utf-8") as f:
            report = json.load(f)
        report["final_model"]["effects"].append("drift")
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "drift.json")
            with open(path, "w", encoding="utf-8") as f:
                json.dump(report, f)
            with self.assertRaises(sim.ValidationError) as e:
                sim.check(sim.load_config(os.path.join(ARGS.source_dir, "config/tribod.textproto")),
                          sim.load_protocol(self.protocol, friction_model=path))
        self.assertEqual(e.exception.field, "friction_compensation.report_json")
        self.assertIn("final_model.effects has drift", e.exception.message)


if __name__ == "__main__":
    support.main()
