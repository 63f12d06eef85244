"""tribo-campaign SPEC: simulated runs on Dask, one results table (docs/campaigns.md).

    tribo-campaign config/campaigns/identification_reliability_tiny.toml --out results/tiny
    tribo-campaign SPEC --scheduler tcp://10.0.0.5:8786     # an existing cluster
    tribo-campaign SPEC --dry-run                            # expand and validate only

Exit codes: 0 every run done; 1 some runs failed (rerun to retry them);
2 the spec was refused (nothing ran).
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
    parser.add_argument("--workers", type=int, help="local cluster: worker processes (default: one per core)")
    parser.add_argument("--limit", type=int, help="run at most this many new runs, then stop (resumable)")
    parser.add_argument("--dry-run", action="store_true", help="expand and validate the spec, run nothing")
    parser.add_argument("--version", action="version", version=_version())
    args = parser.parse_args(argv)

    from tribo_client import sim
    from .results import write_results
    from .runner import run_campaign
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
    done, skipped, failed = run_campaign(campaign, out_dir, scheduler=args.scheduler, workers=args.workers,
                                         limit=args.limit)
    frame = write_results(out_dir, campaign.name, campaign.spec_path)
    if campaign.report.get("kind") == "identification_reliability" and len(frame):
        from .reliability import write_reliability
        write_reliability(frame, out_dir, campaign.report, campaign.name)
    if campaign.tasks and "scorecard" in campaign.tasks[0].compute and len(frame):
        from .scorecard_sweep import write_scorecard_sweep
        write_scorecard_sweep(campaign, out_dir)
    if failed and "error" in frame:
        errors = frame.loc[frame["status"] != "ok", "error"]
        if len(errors):
            print(f"first failure: {errors.iloc[0]}", file=sys.stderr)
    print(f"{done} runs now, {skipped} done before, {failed} failed; table: "
          f"{os.path.join(out_dir, 'results.csv')} and results.h5", file=sys.stderr)
    return 1 if failed else 0


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
