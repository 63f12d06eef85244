"""The scorecard of every run of a campaign with compute = ["scorecard"]
(docs/campaigns.md). Writes
  scorecard.csv        one row per run and scorecard observation: the run's
                       key, seed, variant, tags and grid values, then the
                       scorecard's own columns (source, observation, unit,
                       dissertation, simulated, error, error_in_points, goal,
                       within_goal), as tribo-scorecard --json gives them
  scorecard_sweep.png  with [report] kind = "scorecard_sweep": chosen
                       observations against the grid column `x`, one line per
                       value of the grid column `lines` (optional), the
                       dissertation's value dashed, the base config's x dotted;
                       the last panel counts the rows within the scorecard's goals
(NAME.partial.EXT when runs are left: results.py)"""

import json
import os

from .runner import RESULT_FILE, run_dir

SCORECARD_COLUMNS = ("source", "observation", "unit", "dissertation", "simulated", "error", "error_in_points",
                     "goal", "within_goal")


def scorecard_frame(campaign, out_dir):
    """The long table, in the order the spec expands; runs without a
    finished scorecard are left out."""
    import pandas as pd
    records = []
    for task in campaign.tasks:
        path = os.path.join(run_dir(out_dir, task.key), RESULT_FILE)
        if not os.path.exists(path):
            continue
        with open(path, encoding="utf-8") as f:
            report = json.load(f).get("scorecard")
        if not report:
            continue
        for r in report["rows"]:
            record = {"key": task.key, "seed": task.seed}
            record.update(task.labels)
            record.update({c: r[c] for c in SCORECARD_COLUMNS})
            records.append(record)
    return pd.DataFrame(records)


def write_scorecard_sweep(campaign, out_dir, partial=False):
    from .results import output_path
    frame = scorecard_frame(campaign, out_dir)
    frame.to_csv(output_path(out_dir, "scorecard.csv", partial), index=False)
    report = campaign.report
    if report.get("kind") == "scorecard_sweep" and len(frame):
        plot_sweep(frame, report, output_path(out_dir, "scorecard_sweep.png", partial),
                   campaign.name + (" (partial)" if partial else ""),
                   _base_value(campaign.base_config_path, report["x"]))
    return frame


def _base_value(config_path, field_path):
    """The base config's value of a field path (before the spec's overrides)."""
    from google.protobuf import text_format
    from tribo.v1 import daemon_config_pb2
    with open(config_path, encoding="utf-8") as f:
        message = text_format.Parse(f.read(), daemon_config_pb2.DaemonConfig())
    for part in field_path.split("."):
        message = getattr(message, part)
    return message


def plot_sweep(frame, report, path, title, base_x=None):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    x, lines = report["x"], report.get("lines")
    observations = list(report.get("observations", []))
    panels = len(observations) + 1
    columns = min(3, panels)
    rows = (panels + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.0 * rows), squeeze=False)
    line_values = sorted(frame[lines].unique()) if lines else [None]
    for ax, observation in zip(axes.flat, observations):
        subset = frame[frame["observation"] == observation]
        if subset.empty:
            ax.set_title(f"{observation}: not in the scorecard", fontsize=7)
            continue
        for value in line_values:
            part = subset if value is None else subset[subset[lines] == value]
            mean = part.groupby(x)["simulated"].mean()  # over seeds
            ax.plot(mean.index, mean.to_numpy(), marker="o", ms=3, lw=1,
                    label=None if value is None else f"{_short(lines)} = {value:g}")
        ax.axhline(subset["dissertation"].iloc[0], color="k", ls="--", lw=0.8, label="dissertation")
        if base_x is not None:
            ax.axvline(base_x, color="0.5", ls=":", lw=0.8)
        ax.set_title(f"{subset['source'].iloc[0]}: {observation}", fontsize=7)
        ax.set_ylabel(subset["unit"].iloc[0] or "-", fontsize=7)
        ax.set_xlabel(_short(x), fontsize=7)
        ax.tick_params(labelsize=7)
    ax = axes.flat[len(observations)]
    for value in line_values:
        part = frame if value is None else frame[frame[lines] == value]
        counts = part.groupby([x, "key"])["within_goal"].sum().groupby(level=0).mean()
        ax.plot(counts.index, counts.to_numpy(), marker="o", ms=3, lw=1,
                label=None if value is None else f"{_short(lines)} = {value:g}")
    if base_x is not None:
        ax.axvline(base_x, color="0.5", ls=":", lw=0.8)
    goals = frame[frame["goal"] > 0].groupby("key").size()
    ax.set_title(f"rows within issue 14's goals (of {int(goals.max()) if len(goals) else 0})", fontsize=7)
    ax.set_xlabel(_short(x), fontsize=7)
    ax.tick_params(labelsize=7)
    if lines:
        ax.legend(fontsize=6)
    for extra in list(axes.flat)[panels:]:
        extra.set_visible(False)
    fig.suptitle(f"{title}: {frame['key'].nunique()} runs", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=150, bbox_inches="tight")
    plt.close(fig)


def _short(path):
    return ".".join(path.split(".")[-2:])
