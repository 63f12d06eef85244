#!/usr/bin/python3
"""tribo-campaign, in-process and on a 2-worker Dask LocalCluster
(127.0.0.1): the expected results table, every row rerunnable exactly; a
killed campaign finishes the rest on restart without redoing finished runs;
Ctrl-C stops it cleanly, keeping the runs done; a limited campaign writes
its tables under .partial names; runs batched into Dask tasks on an existing
scheduler, which the campaign leaves without a word on stderr; the progress
line within 80 columns; a bad override path or value is refused before any
run starts, naming the field; the tiny identification reliability map.

    /usr/bin/python3 tests/python/test_campaign.py --build-dir build --source-dir .
(PYTHONPATH must hold client/python and build/python.)"""

import glob
import io
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import numpy as np
import pandas as pd
from google.protobuf import text_format

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import support
from support import ARGS, short_protocol  # noqa: E402

from tribo_client import sim  # noqa: E402
from tribo_client.campaign.batches import RunCost, batch_size  # noqa: E402
from tribo_client.campaign.progress import Progress  # noqa: E402
from tribo_client.campaign.results import read_hdf5  # noqa: E402

# Every line tribo-campaign writes to stderr on a run that goes well (no
# warning, no traceback, nothing from Dask).
OWN_LINE = re.compile(r"^(campaign \S+: \d+ runs -> |\[[#.]*\] \d+/\d+ runs, |\d+ runs now, \d+ done before, |runs: "
                      r"|partial campaign \()")


def foreign_lines(stderr):
    return [line for line in stderr.splitlines() if line and not OWN_LINE.match(line)]


def campaign(*args, timeout=300, **kwargs):
    return subprocess.run([sys.executable, "-m", "tribo_client.campaign", *args], capture_output=True, text=True,
                          timeout=timeout, **kwargs)


def write_spec(directory, body, protocol=None):
    protocol_path = os.path.join(directory, "protocol.textproto")
    with open(protocol_path, "w", encoding="utf-8") as f:
        f.write(text_format.MessageToString(protocol or short_protocol()))
    path = os.path.join(directory, "spec.toml")
    with open(path, "w", encoding="utf-8") as f:
        f.write(f'config = "{os.path.join(ARGS.source_dir, "config/tribod.textproto")}"\n')
        f.write(body)
        f.write('\n[[protocols]]\npath = "protocol.textproto"\n')
    return path


class CampaignTable(unittest.TestCase):
    def test_grid_of_runs_gives_the_expected_table(self):
        with tempfile.TemporaryDirectory() as tmp:
            spec = write_spec(tmp, 'name = "grid"\nseeds = [1, 2]\ncompute = ["metrics"]\n'
                                   '[grid]\n"sim.friction.coulomb_coeff" = [0.08, 0.12]\n')
            out = os.path.join(tmp, "out")
            result = campaign(spec, "--out", out, "--workers", "2")
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertIn("4/4 runs", result.stderr)  # the progress bar's last line
            self.assertEqual(foreign_lines(result.stderr), [])
            self.assertTrue(all(len(line) <= 80 for line in result.stderr.splitlines() if "/4 runs" in line),
                            result.stderr)
            # Four sub-second runs cost less than starting a cluster: all done in this process.
            self.assertIn("runs: 4 in this process", result.stderr)
            self.assertFalse(os.path.exists(os.path.join(out, ".dask-worker-space")), "a cluster was started")
            table = pd.read_csv(os.path.join(out, "results.csv"), float_precision="round_trip")
            self.assertEqual(len(table), 4)
            self.assertEqual(sorted(zip(table["sim.friction.coulomb_coeff"], table["seed"])),
                             [(0.08, 1), (0.08, 2), (0.12, 1), (0.12, 2)])
            self.assertTrue((table["status"] == "ok").all())
            self.assertTrue((table["exit_status"] == "SUCCESS").all())
            self.assertEqual(set(table["software_version"]), {sim.software_version})
            # Each row reruns exactly from its recorded config, protocol and seed.
            for row in table.itertuples():
                folder = os.path.join(out, row.run_folder)
                config = sim.load_config(os.path.join(folder, "config.textproto"))
                rerun = sim.simulate(config, os.path.join(folder, "protocol.textproto"), seed=row.seed)
                mu = np.mean([s["mu"] for s in sim.metrics(rerun)["scratches"]])
                self.assertEqual(mu, row.mu_mean)
            # More Coulomb friction, more µ, seed by seed (the 1 s scratch is
            # still in the Stribeck transient: less than the 0.04 difference).
            by = table.set_index(["seed", "sim.friction.coulomb_coeff"])["mu_mean"]
            for seed in (1, 2):
                self.assertGreater(by[(seed, 0.12)], by[(seed, 0.08)])
            # The HDF5 table holds the same.
            h5 = read_hdf5(os.path.join(out, "results.h5"))
            np.testing.assert_array_equal(h5["mu_mean"].to_numpy(), table["mu_mean"].to_numpy())
            self.assertEqual(list(h5["key"]), list(table["key"]))

    def test_killed_campaign_finishes_the_rest_without_redoing(self):
        with tempfile.TemporaryDirectory() as tmp:
            protocol = sim.load_protocol(os.path.join(ARGS.source_dir, "config/protocols/identification.textproto"))
            spec = write_spec(tmp, 'name = "kill"\nseeds = {first = 1, count = 4}\ncompute = ["metrics"]\n'
                                   '[overrides]\n"controller.lateral_displacement.setpoint_weight_p" = 1.0\n',
                              protocol)
            out = os.path.join(tmp, "out")
            proc = subprocess.Popen([sys.executable, "-m", "tribo_client.campaign", spec, "--out", out,
                                     "--workers", "2"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                    start_new_session=True)
            try:
                deadline = time.monotonic() + 240
                while not glob.glob(os.path.join(out, "runs", "*", "result.json")):
                    self.assertIsNone(proc.poll(), "the campaign ended before it could be killed")
                    self.assertLess(time.monotonic(), deadline)
                    time.sleep(0.02)
            finally:
                os.killpg(proc.pid, signal.SIGKILL)  # the driver and its local cluster
                proc.wait()
            finished = {p: os.stat(p).st_mtime_ns for p in glob.glob(os.path.join(out, "runs", "*", "result.json"))}
            self.assertGreaterEqual(len(finished), 1)
            self.assertLess(len(finished), 4)
            result = campaign(spec, "--out", out, "--workers", "2")
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertIn(f"{4 - len(finished)} runs now, {len(finished)} done before", result.stderr)
            for path, mtime in finished.items():
                self.assertEqual(os.stat(path).st_mtime_ns, mtime, f"{path} was redone")
            table = pd.read_csv(os.path.join(out, "results.csv"), float_precision="round_trip")
            self.assertEqual(sorted(table["seed"]), [1, 2, 3, 4])


def identification_spec(tmp, name, seeds):
    """SEEDS runs of the 198 s identification protocol (about 2 s each: a
    local cluster starts)."""
    protocol = sim.load_protocol(os.path.join(ARGS.source_dir, "config/protocols/identification.textproto"))
    return write_spec(tmp, f'name = "{name}"\nseeds = {{first = 1, count = {seeds}}}\ncompute = ["metrics"]\n'
                           '[overrides]\n"controller.lateral_displacement.setpoint_weight_p" = 1.0\n', protocol)


def results_done(out):
    return glob.glob(os.path.join(out, "runs", "*", "result.json"))


class Interrupted(unittest.TestCase):
    def test_ctrl_c_stops_cleanly_and_keeps_the_runs_done(self):
        with tempfile.TemporaryDirectory() as tmp:
            spec = identification_spec(tmp, "interrupted", 6)
            out = os.path.join(tmp, "out")
            # Its own session, as a terminal's process group: SIGINT goes to every process in it.
            proc = subprocess.Popen([sys.executable, "-m", "tribo_client.campaign", spec, "--out", out,
                                     "--workers", "2"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                    text=True, start_new_session=True)
            try:
                deadline = time.monotonic() + 240
                while len(results_done(out)) < 2:
                    self.assertIsNone(proc.poll(), "the campaign ended before it could be interrupted")
                    self.assertLess(time.monotonic(), deadline)
                    time.sleep(0.02)
                os.killpg(proc.pid, signal.SIGINT)
                stderr = proc.communicate(timeout=120)[1]
            finally:
                if proc.poll() is None:
                    os.killpg(proc.pid, signal.SIGKILL)
                    proc.wait()
            self.assertEqual(proc.returncode, 130, stderr)
            self.assertNotIn("Traceback", stderr)
            self.assertNotIn("KeyboardInterrupt", stderr)
            kept = len(results_done(out))
            self.assertGreaterEqual(kept, 2)
            self.assertLess(kept, 6)
            self.assertIn(f"interrupted: {kept} of 6 runs done, kept in {os.path.join(out, 'runs')}", stderr)
            self.assertIn(f"; {6 - kept} not run", stderr)
            self.assertFalse(os.path.exists(os.path.join(out, "results.csv")))
            # Nothing of it is left running: no worker, no forkserver.
            deadline = time.monotonic() + 30
            while True:
                try:
                    os.killpg(proc.pid, 0)
                except ProcessLookupError:
                    break
                self.assertLess(time.monotonic(), deadline, "processes of the campaign outlived it")
                time.sleep(0.1)
            result = campaign(spec, "--out", out, "--workers", "2")
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertIn(f"{6 - kept} runs now, {kept} done before", result.stderr)


class Limited(unittest.TestCase):
    def test_a_limited_campaign_says_so_and_keeps_the_full_table(self):
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "out")
            spec = write_spec(tmp, 'name = "limited"\nseeds = [1, 2]\ncompute = ["metrics"]\n')
            result = campaign(spec, "--out", out)
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertNotIn("partial", result.stderr)
            full = os.path.join(out, "results.csv")
            before = os.stat(full).st_mtime_ns
            # Two more seeds, of which --limit 1 runs one.
            spec = write_spec(tmp, 'name = "limited"\nseeds = [1, 2, 3, 4]\ncompute = ["metrics"]\n')
            result = campaign(spec, "--out", out, "--limit", "1")
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertIn("partial campaign (--limit 1): 3 of 4 runs done, 1 left", result.stderr)
            self.assertIn("results.partial.csv", result.stderr)
            self.assertEqual(foreign_lines(result.stderr), [])
            self.assertEqual(os.stat(full).st_mtime_ns, before, "the complete campaign's table was rewritten")
            self.assertEqual(len(pd.read_csv(full)), 2)
            partial = pd.read_csv(os.path.join(out, "results.partial.csv"))
            self.assertEqual(sorted(partial["seed"]), [1, 2, 3])
            self.assertTrue(os.path.exists(os.path.join(out, "results.partial.h5")))
            # Finished: the table of all four, and no partial file left to mislead.
            result = campaign(spec, "--out", out)
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertEqual(sorted(pd.read_csv(full)["seed"]), [1, 2, 3, 4])
            self.assertEqual(glob.glob(os.path.join(out, "*.partial.*")), [])


class ProgressLine(unittest.TestCase):
    class Terminal(io.StringIO):
        def isatty(self):
            return True

    def test_within_80_columns_off_a_terminal(self):
        stream = io.StringIO()
        progress = Progress(123456, 23456, stream)
        for _ in range(100000):
            progress.advance(True)
        lines = stream.getvalue().splitlines()
        self.assertGreater(len(lines), 5)
        self.assertLessEqual(max(map(len, lines)), 79, lines[-1])
        self.assertIn("123456/123456 runs, 23456 before, 0 failed", lines[-1])

    def test_within_the_terminal_width(self):
        for columns in (80, 60, 40):
            stream = self.Terminal()
            progress = Progress(40, 4, stream, columns=columns)
            for i in range(36):
                progress.advance(i % 7 != 0)
            drawn = stream.getvalue().replace("\n", "\r").split("\r")
            self.assertTrue(all(len(d) < columns for d in drawn), (columns, max(drawn, key=len)))
            self.assertTrue(drawn[-2].rstrip().endswith("ETA 0 s") or columns < 60, drawn[-2])


class Batches(unittest.TestCase):
    def test_batch_size(self):
        self.assertEqual(batch_size(None, 40, 2), 1)      # cost unknown: one run per task
        self.assertEqual(batch_size(0.1, 400, 2), 10)     # tasks of about 1 s
        self.assertEqual(batch_size(0.1, 12, 2), 2)       # three tasks per slot left
        self.assertEqual(batch_size(5.0, 400, 2), 1)      # a long run alone
        self.assertEqual(batch_size(0.01, 1, 8), 1)
        self.assertEqual(batch_size(0.1, 0, 2), 0)

    def test_run_cost_is_the_median_of_recent_runs(self):
        cost = RunCost()
        self.assertIsNone(cost.per_run_s)
        for wall in (0.2, 0.1, 9.0, 0.3):
            cost.add({"wall_s": wall})
        cost.add({"status": "error"})  # a failed run carries no wall_s
        self.assertAlmostEqual(cost.per_run_s, 0.25)


class ExistingScheduler(unittest.TestCase):
    """The multi-machine path of docs/campaigns.md, on one machine:
    dask-scheduler and dask-worker started here, the campaign pointed at them."""

    def test_campaign_runs_on_a_running_scheduler(self):
        with tempfile.TemporaryDirectory() as tmp:
            env = dict(os.environ)
            env["PYTHONPATH"] = os.pathsep.join(os.path.abspath(p) for p in env.get("PYTHONPATH", "").split(os.pathsep) if p)
            scheduler = subprocess.Popen(["/usr/bin/dask-scheduler", "--host", "127.0.0.1", "--port", "0",
                                          "--no-dashboard"], stderr=subprocess.PIPE, text=True, env=env, cwd=tmp)
            worker = None
            try:
                address = None
                for line in scheduler.stderr:
                    if "Scheduler at:" in line:
                        address = line.split()[-1]
                        break
                self.assertTrue(address and address.startswith("tcp://127.0.0.1:"), address)
                # Keep reading its log so that a full pipe never blocks it.
                threading.Thread(target=lambda: [None for _ in scheduler.stderr], daemon=True).start()
                worker = subprocess.Popen(["/usr/bin/dask-worker", address, "--nworkers", "1", "--nthreads", "1",
                                           "--no-dashboard", "--local-directory", tmp],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, cwd=tmp)
                spec = write_spec(tmp, 'name = "remote"\nseeds = {first = 1, count = 16}\ncompute = ["metrics"]\n')
                out = os.path.join(tmp, "out")
                result = campaign(spec, "--out", out, "--scheduler", address, timeout=120)
                self.assertEqual(result.returncode, 0, result.stderr)
                # It exits cleanly: nothing on stderr but its own lines (no Dask warning, no traceback).
                self.assertEqual(foreign_lines(result.stderr), [])
                table = pd.read_csv(os.path.join(out, "results.csv"))
                self.assertEqual(sorted(table["seed"]), list(range(1, 17)))
                self.assertTrue((table["exit_status"] == "SUCCESS").all())
                self.assertEqual(len(results_done(out)), 16)  # a folder per run, batched or not
                # Sub-second runs travel several to a task once the first ones gave their cost.
                where = re.search(r"runs: 16 on the cluster in (\d+) tasks of 1-(\d+) runs", result.stderr)
                self.assertIsNotNone(where, result.stderr)
                self.assertLess(int(where.group(1)), 16)
                self.assertGreater(int(where.group(2)), 1)
                # The runner this replaced left "Future exception was never retrieved" at exit in about
                # one campaign of ten on a loaded machine: a few more campaigns, each clean.
                for again in range(3):
                    result = campaign(spec, "--out", os.path.join(tmp, f"again{again}"), "--scheduler", address,
                                      timeout=120)
                    self.assertEqual(result.returncode, 0, result.stderr)
                    self.assertEqual(foreign_lines(result.stderr), [])
            finally:
                for proc in (worker, scheduler):
                    if proc is not None:
                        proc.terminate()
                        proc.wait(timeout=30)
                scheduler.stderr.close()


def assert_refused(test, tmp, spec, field):
    """The campaign refuses SPEC before any run, naming FIELD, and writes nothing; returns its stderr."""
    out = os.path.join(tmp, "out")
    result = campaign(spec, "--out", out, timeout=60)
    test.assertEqual(result.returncode, 2, result.stderr)
    test.assertIn("refused before any run", result.stderr)
    test.assertIn(field, result.stderr)
    test.assertFalse(os.path.exists(out), "nothing may run or be written")
    return result.stderr


class RefusedSpecs(unittest.TestCase):
    def refused(self, body, field):
        with tempfile.TemporaryDirectory() as tmp:
            return assert_refused(self, tmp, write_spec(tmp, body), field)

    def test_unknown_override_path_names_the_field(self):
        stderr = self.refused('[grid]\n"sim.friction.coulomb_coef" = [0.1]\n', "sim.friction.coulomb_coef")
        self.assertIn("has no field 'coulomb_coef'", stderr)

    def test_unknown_variant_override_path(self):
        self.refused('[[variants]]\nlabel = "x"\noverrides = { "sim.frction.coulomb_coeff" = 0.1 }\n',
                     "sim.frction.coulomb_coeff")

    def test_unknown_base_model_names_the_field(self):
        self.refused('[diagnosis]\nbase_model = "maxwell"\n', "diagnosis.base_model")

    def test_value_the_validator_refuses_names_the_field(self):
        self.refused('[grid]\n"controller.loop_rate_hz" = [10000, -1]\n', "controller.loop_rate_hz")

    def test_missing_spec_file_is_refused(self):
        with tempfile.TemporaryDirectory() as tmp:
            stderr = assert_refused(self, tmp, os.path.join(tmp, "no-such-spec.toml"), "no-such-spec.toml")
            self.assertNotIn("Traceback", stderr)


class FrictionModels(unittest.TestCase):
    """A campaign compares runs with and without the friction compensation."""

    def test_variants_with_and_without_a_friction_model(self):
        from tribo_client.campaign.spec import load_spec
        report = os.path.join(ARGS.source_dir, "tests/data/friction_reports/identification.json")
        with tempfile.TemporaryDirectory() as tmp:
            spec = write_spec(tmp, f'[[variants]]\nlabel = "without"\n[[variants]]\nlabel = "compensated"\n'
                                   f'friction_model = "{report}"\n')
            tasks = load_spec(spec, validate=lambda config, protocol: sim.check(config, protocol)).tasks
        self.assertEqual(len(tasks), 2)
        from tribo.v1 import protocol_pb2
        plain, compensated = protocol_pb2.Protocol(), protocol_pb2.Protocol()
        plain.ParseFromString(tasks[0].protocol_bytes)
        compensated.ParseFromString(tasks[1].protocol_bytes)
        self.assertFalse(plain.HasField("friction_compensation"))
        with open(report, encoding="utf-8") as f:
            self.assertEqual(compensated.friction_compensation.report_json, f.read())
        self.assertEqual(tasks[1].labels["friction_model"], report)
        self.assertNotIn("friction_model", tasks[0].labels)
        self.assertNotEqual(tasks[0].key, tasks[1].key)

    def test_an_unreadable_model_is_refused_naming_the_key(self):
        with tempfile.TemporaryDirectory() as tmp:
            assert_refused(self, tmp, write_spec(tmp, 'friction_model = "no-such-report.json"\n'), "friction_model")


def run_shipped_spec(test, tmp, name, timeout):
    """Runs config/campaigns/NAME on 2 local workers into TMP/out; returns that directory."""
    out = os.path.join(tmp, "out")
    result = campaign(os.path.join(ARGS.source_dir, "config/campaigns", name), "--out", out, "--workers", "2",
                      timeout=timeout)
    test.assertEqual(result.returncode, 0, result.stderr)
    return out


class ReliabilityMap(unittest.TestCase):
    def test_tiny_identification_reliability_map(self):
        with tempfile.TemporaryDirectory() as tmp:
            out = run_shipped_spec(self, tmp, "identification_reliability_tiny.toml", timeout=400)
            table = pd.read_csv(os.path.join(out, "reliability.csv"))
            self.assertEqual(sorted(table["effect"]), ["direction_asymmetry", "none"])
            self.assertTrue(table["runs"].eq(1).all())
            self.assertTrue(table["false_positive_rate"].between(0, 1).all())
            confusion = pd.read_csv(os.path.join(out, "confusion.csv"), index_col=0)
            np.testing.assert_allclose(confusion.sum(axis=1).to_numpy(), 1.0)
            self.assertIn("nothing", confusion.columns)
            self.assertGreater(os.path.getsize(os.path.join(out, "confusion.png")), 5000)
            print("\n" + table.to_string() + "\n" + confusion.to_string(), file=sys.stderr)

    def test_base_effects_are_found_not_false_positives(self):
        from tribo_client.campaign.reliability import reliability_tables
        frame = pd.DataFrame({"status": ["ok"] * 3, "effect": ["none", "direction_asymmetry", "none"],
                              "strength": [0.0, 0.05, 0.0],
                              "accepted_effects": ["rate_state", "rate_state;direction_asymmetry", "drift"]})
        plain, confusion = reliability_tables(frame)
        self.assertEqual(list(plain["false_positive_rate"]), [1.0, 1.0])  # direction_asymmetry, none
        self.assertEqual(confusion.loc["direction_asymmetry", "rate_state"], 1.0)
        table, confusion = reliability_tables(frame, base_effects=["rate_state"])
        by = table.set_index("effect")
        self.assertEqual(by.loc["direction_asymmetry", "false_positive_rate"], 0.0)
        self.assertEqual(by.loc["direction_asymmetry", "detection_rate"], 1.0)
        self.assertEqual(by.loc["none", "false_positive_rate"], 0.5)  # drift is not in the plant
        self.assertEqual(by.loc["none", "found_rate_state"], 0.5)
        self.assertEqual(confusion.loc["direction_asymmetry", "direction_asymmetry"], 1.0)
        self.assertEqual(confusion.loc["none", "nothing"], 0.5)


def scorecard_json(*args):
    """tribo-scorecard --json, the binary's own figures."""
    result = subprocess.run([os.path.join(ARGS.build_dir, "scorecard", "tribo-scorecard"), "--json", *args],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


class ShippedSpecs(unittest.TestCase):
    def test_every_spec_under_config_campaigns_expands_and_validates(self):
        expected = {"identification_reliability.toml": 130, "identification_reliability_lugre_plain.toml": 130,
                    "identification_reliability_contact_choice.toml": 130,
                    "identification_reliability_full.toml": 675, "creep_holds.toml": 35,
                    "identification_reliability_small.toml": 15, "identification_reliability_tiny.toml": 2,
                    "scorecard_sweep.toml": 25, "scorecard_sweep_tiny.toml": 2}
        specs = sorted(glob.glob(os.path.join(ARGS.source_dir, "config/campaigns/*.toml")))
        self.assertEqual(sorted(os.path.basename(p) for p in specs), sorted(expected))
        for spec in specs:
            result = campaign(spec, "--dry-run", timeout=120)
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertIn(f": {expected[os.path.basename(spec)]} runs", result.stderr)


class ScorecardSweep(unittest.TestCase):
    """compute = ["scorecard"]: the reproduction scorecard per config and seed."""

    def test_tiny_sweep_table_equals_the_scorecard_binary(self):
        with tempfile.TemporaryDirectory() as tmp:
            out = run_shipped_spec(self, tmp, "scorecard_sweep_tiny.toml", timeout=300)
            path = "sim.friction.rate_state.direct_coeff"
            runs = pd.read_csv(os.path.join(out, "results.csv"), float_precision="round_trip")
            self.assertEqual(sorted(runs[path]), [0.0218378, 0.03])
            self.assertTrue((runs["status"] == "ok").all())
            # Table 5.1: 5 rows (Fs both ways, ts, ds, dl) x 8, 3 overshoots, 2 accelerations, 1 eq. 28, 4 trends
            self.assertTrue(runs["scorecard_rows"].eq(50).all())
            self.assertTrue(runs["scorecard_goals"].eq(24).all())  # Fs, ts, dl of eight conditions
            table = pd.read_csv(os.path.join(out, "scorecard.csv"), float_precision="round_trip")
            self.assertEqual(list(table.columns),
                             ["key", "seed", "variant", path, "source", "observation", "unit", "dissertation",
                              "simulated", "error", "error_in_points", "goal", "within_goal"])
            self.assertEqual(len(table), 2 * 50)
            # The spec's base config's row is the binary's own scorecard, figure for figure.
            own = scorecard_json("--config", os.path.join(ARGS.source_dir, "config/instruments/fitted_contact.textproto"),
                                 "--group", "table_5_1", "--quick", "--seed", "1")["rows"]
            default = table[table[path] == 0.0218378]
            self.assertEqual(list(default["observation"]), [r["observation"] for r in own])
            self.assertEqual(list(default["simulated"]), [r["simulated"] for r in own])
            # A row the dissertation gives no number for is null in JSON, empty (NaN) in the CSV.
            self.assertEqual([None if pd.isna(x) else x for x in default["dissertation"]],
                             [r["dissertation"] for r in own])
            # The other row reruns exactly from its recorded config and seed.
            other = runs[runs[path] == 0.03].iloc[0]
            rerun = scorecard_json("--config", os.path.join(out, other["run_folder"], "config.textproto"),
                                   "--group", "table_5_1", "--quick", "--seed", str(other["seed"]))["rows"]
            self.assertEqual(list(table[table["key"] == other["key"]]["simulated"]), [r["simulated"] for r in rerun])
            # A stronger direct effect a widens the rise of Fs from 0.2 to 36 um/s.
            fs = table.pivot(index="observation", columns=path, values="simulated")
            rise = fs.loc["Fs at 9810 uN, 36.0 um/s"] - fs.loc["Fs at 9810 uN, 0.2 um/s"]
            self.assertGreater(rise[0.03], rise[0.0218378] + 50e0)
            self.assertGreater(os.path.getsize(os.path.join(out, "scorecard_sweep.png")), 5000)

    def refused(self, body, field):
        with tempfile.TemporaryDirectory() as tmp:
            spec = os.path.join(tmp, "spec.toml")
            with open(spec, "w", encoding="utf-8") as f:
                f.write(f'config = "{os.path.join(ARGS.source_dir, "config/tribod.textproto")}"\n'
                        'compute = ["scorecard"]\n' + body)
            return assert_refused(self, tmp, spec, field)

    def test_bad_parameter_path_names_the_field(self):
        stderr = self.refused('[grid]\n"sim.friction.rate_state.direct_coef" = [0.02]\n',
                              "sim.friction.rate_state.direct_coef")
        self.assertIn("has no field 'direct_coef'", stderr)

    def test_unknown_base_model_names_the_field(self):
        self.refused('[diagnosis]\nbase_model = "maxwell"\n', "diagnosis.base_model")

    def test_value_the_validator_refuses_names_the_field(self):
        self.refused('[grid]\n"sim.friction.contact_stiffness_n_per_m" = [3000, -1]\n',
                     "contact_stiffness_n_per_m")

    def test_unknown_group_is_refused(self):
        stderr = self.refused('[scorecard]\ngroups = ["table_5_1", "table_5_2"]\n', "scorecard.groups")
        self.assertIn("table_5_2", stderr)

    def test_protocols_with_a_scorecard_only_campaign_are_refused(self):
        self.refused('[[protocols]]\npath = "x.textproto"\n', "protocols")

    def test_plot_column_must_be_swept(self):
        self.refused('[grid]\n"sim.friction.rate_state.direct_coeff" = [0.02]\n'
                     '[report]\nkind = "scorecard_sweep"\nx = "sim.friction.rate_state.state_coeff"\n', "report.x")


if __name__ == "__main__":
    support.main()
