"""tribo-campaign SPEC: simulated runs on Dask, one results table (docs/campaigns.md).

    tribo-campaign config/campaigns/identification_reliability_tiny.toml --out results/tiny
    tribo-campaign SPEC --scheduler tcp://10.0.0.5:8786     # an existing cluster
    tribo-campaign SPEC --dry-run                            # expand and validate only

    tribo-campaign SPEC --limit 3                            # a trial: at most 3 new runs

Exit codes: 0 every run done, or --limit reached (the tables are then
results.partial.csv, ...: results.csv is written once every run is done);
1 some runs failed (rerun to retry them); 2 the spec was refused (nothing
ran); 130 interrupted (Ctrl-C: the runs done are kept, rerun to finish).
"""

import argparse
import os
import sys


def main(argv=None):
    parser = argparse.ArgumentParser(prog="tribo-campaign", description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="\n".join(__doc__.splitlines()[1:]))
    parser.add_argument("spec", help="the campaign spec (TOML)")
    parser.add_argument("--out", help="results directory (default: campaigns/<name> in the current directory)")
    parser.add_argument("--scheduler", help="address of a running Dask scheduler, e.g. tcp://HOST:8786 "
                                            "(default: a local cluster on 127.0.0.1)")
    parser.add_argument("--workers", type=int, help="local cluster: worker processes (default: one per core), "
                                                    "started once the runs left would take over 3 s in this "
                                                    "process; 1: every run in this process")
    parser.add_argument("--limit", type=int, help="run at most this many new runs, then stop (resumable; the "
                                                  "tables are then named *.partial.*)")
    parser.add_argument("--dry-run", action="store_true", help="expand and validate the spec, run nothing")
    parser.add_argument("--version", action="version", version=_version())
    args = parser.parse_args(argv)

    try:
        return _campaign(args)
    except KeyboardInterrupt:  # the runs handle their own (runner.py); this is before or after them
        print("\ntribo-campaign: interrupted", file=sys.stderr)
        return 130


def _campaign(args):
    from tribo_client import sim
    from .spec import SpecError, load_spec

    def validate(config_bytes, protocol_bytes):
        sim.load_config(config_bytes_message(config_bytes))
        if protocol_bytes:  # a scorecard-only campaign has none
            sim.check(config_bytes_message(config_bytes), protocol_bytes_message(protocol_bytes))

    try:
        campaign = load_spec(args.spec, validate)
    except (SpecError, sim.ValidationError) as e:
        field = getattr(e, "field", "")
        print(f"tribo-campaign: {args.spec}: refused before any run: {e}" +
              (f" (field {field})" if field and field not in str(e) else ""), file=sys.stderr)
        return 2
    out_dir = args.out or os.path.join("campaigns", campaign.name)
    print(f"campaign {campaign.name}: {len(campaign.tasks)} runs -> {out_dir}", file=sys.stderr)
    if args.dry_run:
        return 0
    return _run(campaign, out_dir, args)


def _run(campaign, out_dir, args):
    from .results import output_path, remove_partial_outputs, write_results
    from .runner import run_campaign
    outcome = run_campaign(campaign, out_dir, scheduler=args.scheduler, workers=args.workers, limit=args.limit)
    kept = len(campaign.tasks) - outcome.left
    if outcome.interrupted:
        print(f"tribo-campaign: interrupted: {kept} of {len(campaign.tasks)} runs done, kept in "
              f"{os.path.join(out_dir, 'runs')} ({kept - outcome.skipped} this time, {outcome.skipped} before); "
              f"{outcome.left} not run; no table written: rerun the same command to finish (runs done are "
              "skipped)", file=sys.stderr)
        return 130
    partial = outcome.left > 0
    frame = write_results(out_dir, campaign.name, campaign.spec_path, partial)
    if campaign.report.get("kind") == "identification_reliability" and len(frame):
        from .reliability import write_reliability
        write_reliability(frame, out_dir, campaign.report, campaign.name, partial)
    if campaign.tasks and "scorecard" in campaign.tasks[0].compute and len(frame):
        from .scorecard_sweep import write_scorecard_sweep
        write_scorecard_sweep(campaign, out_dir, partial)
    if not partial:
        remove_partial_outputs(out_dir)
    if outcome.failed and "error" in frame:
        errors = frame.loc[frame["status"] != "ok", "error"]
        if len(errors):
            print(f"first failure: {errors.iloc[0]}", file=sys.stderr)
    print(f"{outcome.attempted} runs now, {outcome.skipped} done before, {outcome.failed} failed; table: "
          f"{output_path(out_dir, 'results.csv', partial)} and .h5", file=sys.stderr)
    if outcome.attempted:
        print(_where(outcome), file=sys.stderr)
    if partial:
        why = f"--limit {args.limit}" if args.limit is not None and not outcome.failed else "runs failed"
        print(f"partial campaign ({why}): {kept} of {len(campaign.tasks)} runs done, {outcome.left} left. "
              "Its tables and figures are named *.partial.*; results.csv is written once every run is "
              "done: rerun the same command" + (" without --limit" if args.limit is not None else ""),
              file=sys.stderr)
    return 1 if outcome.failed else 0


def _where(outcome):
    """Where the runs went: the local default does small campaigns in this process."""
    parts = [f"{outcome.in_process} in this process"] if outcome.in_process or not outcome.task_sizes else []
    if outcome.task_sizes:
        sizes = outcome.task_sizes
        span = f"{min(sizes)}-{max(sizes)}" if min(sizes) != max(sizes) else f"{sizes[0]}"
        parts.append(f"{sum(sizes)} on the cluster in {len(sizes)} tasks of {span} runs")
    return "runs: " + ", ".join(parts)


def config_bytes_message(data):
    from tribo.v1 import daemon_config_pb2
    return daemon_config_pb2.DaemonConfig.FromString(data)


def protocol_bytes_message(data):
    from tribo.v1 import protocol_pb2
    return protocol_pb2.Protocol.FromString(data)


def _version():
    try:
        from tribo_client import sim
        return f"tribo-campaign {sim.software_version}"
    except ImportError:
        from tribo_client import __version__
        return f"tribo-campaign {__version__} (native module not built)"


if __name__ == "__main__":
    sys.exit(main())
