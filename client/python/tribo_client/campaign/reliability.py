"""The identification reliability map of a campaign (report kind
"identification_reliability"): runs tagged with the effect injected into the
simulated instrument (tag `effect`, "none" for clean runs) and its `strength`,
crossed with noise levels (a grid column); per run the diagnosis' accepted
effects. [report] base_effects names effects the base plant holds in every
run (the default contact's rate_state and elasto-plastic presliding): finding
them is right, not a false positive. Writes
  reliability.csv  per effect, strength and noise: runs, detection rate (the
                   injected effect accepted), false-positive rate (any effect
                   accepted that was neither injected nor a base effect), and
                   per base effect the fraction of runs that found it
                   (found_<name>)
  confusion.csv    injected effect (rows) against the first effect the
                   diagnosis accepts that is not a base effect ("nothing"
                   when none), as fractions of the runs
  confusion.png    the same as a heat map (200 dpi)
(NAME.partial.EXT when runs are left: results.py)"""

import os

import numpy as np


def _accepted(value):
    if not isinstance(value, str) or not value:
        return []
    return value.split(";")


def reliability_tables(frame, noise_column=None, base_effects=()):
    import pandas as pd
    base = set(base_effects)
    frame = frame[frame["status"] == "ok"].copy()
    frame["accepted"] = frame["accepted_effects"].map(_accepted)
    frame["named_first"] = frame["accepted"].map(lambda a: next((e for e in a if e not in base), "nothing"))
    frame["detected"] = [row.effect in row.accepted for row in frame.itertuples()]
    frame["false_positive"] = [any(a != row.effect and a not in base for a in row.accepted)
                               for row in frame.itertuples()]
    for effect in base_effects:
        frame[f"found_{effect}"] = frame["accepted"].map(lambda a, e=effect: e in a)
    keys = ["effect", "strength"] + ([noise_column] if noise_column else [])
    grouped = frame.groupby(keys, dropna=False)
    columns = {
        "runs": grouped.size(),
        "detection_rate": grouped["detected"].mean(),
        "false_positive_rate": grouped["false_positive"].mean(),
    }
    for effect in base_effects:
        columns[f"found_{effect}"] = grouped[f"found_{effect}"].mean()
    table = pd.DataFrame(columns).reset_index()
    table.loc[table["effect"] == "none", "detection_rate"] = np.nan  # nothing to detect
    columns = sorted(set(frame["named_first"]) - {"nothing"}) + ["nothing"]
    confusion = pd.crosstab(frame["effect"], frame["named_first"], normalize="index").reindex(
        columns=columns, fill_value=0.0)
    return table, confusion


def plot_confusion(confusion, path, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(4.0 + 0.8 * confusion.shape[1], 2.4 + 0.5 * confusion.shape[0]))
    image = ax.imshow(confusion.to_numpy(), cmap="Blues", vmin=0, vmax=1, aspect="auto")
    ax.set_xticks(range(confusion.shape[1]), confusion.columns, rotation=35, ha="right", fontsize=8)
    ax.set_yticks(range(confusion.shape[0]), confusion.index, fontsize=8)
    ax.set_xlabel("effect the diagnosis names first", fontsize=9)
    ax.set_ylabel("injected effect", fontsize=9)
    for i in range(confusion.shape[0]):
        for j in range(confusion.shape[1]):
            v = confusion.iat[i, j]
            ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=8, color="white" if v > 0.6 else "black")
    bar = fig.colorbar(image, ax=ax)
    bar.set_label("fraction of runs", fontsize=9)
    bar.ax.tick_params(labelsize=8)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=200, bbox_inches="tight")
    plt.close(fig)


def write_reliability(frame, out_dir, report, campaign_name, partial=False):
    from .results import output_path
    noise_column = report.get("noise_column")
    table, confusion = reliability_tables(frame, noise_column, report.get("base_effects", ()))
    table.to_csv(output_path(out_dir, "reliability.csv", partial), index=False)
    confusion.to_csv(output_path(out_dir, "confusion.csv", partial))
    plot_confusion(confusion, output_path(out_dir, "confusion.png", partial),
                   f"{campaign_name}: {int((frame['status'] == 'ok').sum())} runs" + (" (partial)" if partial else ""))
    return table, confusion
