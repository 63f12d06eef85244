"""Figures of a run for a lab notebook: friction and the friction coefficient
µ while sliding, the normal force, the lateral position against its setpoint;
µN, µm and s on the axes; segments shaded and named; legends beside the axes,
never over the data; 200 dpi PNG.

    from tribo_client import read_run, plots
    fig = plots.plot_run(read_run("runs/RUN_ID"), "run.png")
"""

import numpy as np

DPI = 200
# Sliding: the commanded lateral velocity beyond this (the validator's
# slowest allowed speed is 0.1 µm/s) under a positive normal setpoint.
MIN_SLIDING_SPEED_M_PER_S = 0.05e-6


def commanded_velocity_m_per_s(samples):
    t, x = samples["t"], samples["lateral_setpoint"]
    if len(t) < 2:
        return np.zeros_like(t)
    return np.gradient(x, t)


def friction_n(samples):
    """Friction while sliding: the lateral force in the direction opposing the
    commanded motion (positive), NaN where the tip is not sliding under load."""
    v = commanded_velocity_m_per_s(samples)
    sliding = (np.abs(v) > MIN_SLIDING_SPEED_M_PER_S) & (samples["normal_setpoint"] > 0)
    return np.where(sliding, samples["lateral_force"] * np.sign(v), np.nan)


def friction_coefficient(samples):
    """µ = friction / measured normal force while sliding (NaN elsewhere)."""
    normal = samples["normal_force"]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(normal > 0, friction_n(samples) / normal, np.nan)


def segment_spans(samples, names=()):
    """[(index, name, begin_s, end_s)] of the segments in recording order."""
    seg, t = samples["segment"], samples["t"]
    if len(seg) == 0:
        return []
    starts = np.flatnonzero(np.concatenate(([True], seg[1:] != seg[:-1])))
    ends = np.concatenate((starts[1:], [len(seg)]))
    spans = []
    for a, b in zip(starts, ends):
        index = int(seg[a])
        name = names[index] if index < len(names) else f"segment {index}"
        spans.append((index, name, float(t[a]), float(t[b - 1])))
    return spans


def _shade_segments(axes, spans, label_axis, total_s):
    for k, (index, name, begin, end) in enumerate(spans):
        for ax in axes:
            if k % 2:
                ax.axvspan(begin, end, color="0.93", lw=0, zorder=0)
        # A name only where it fits: wider than 6 % of the run.
        if total_s > 0 and (end - begin) / total_s > 0.06:
            label_axis.text((begin + end) / 2, 1.02, f"{index}: {name}", transform=label_axis.get_xaxis_transform(),
                            ha="center", va="bottom", fontsize=7, clip_on=False)


def _annotate_scratches(ax_f, ax_mu, spans, scratches):
    """The steady mean friction and µ of each loaded sliding segment (the
    scratch metrics of tribo-fit metrics), written over its segment."""
    where = {index: (begin, end) for index, _, begin, end in spans}
    for s in scratches:
        if s["segment"] not in where:
            continue
        middle = sum(where[s["segment"]]) / 2
        ax_f.annotate(f"steady friction {s['mean_friction_n'] * 1e6:.1f} µN", (middle, 0.04), xycoords=("data", "axes fraction"),
                      ha="center", fontsize=8, color="C0")
        ax_mu.annotate(f"steady µ = {s['mu']:.4f}", (middle, 0.06), xycoords=("data", "axes fraction"),
                       ha="center", fontsize=8, color="C3")


def plot_run(run, path=None, title=None, metrics=None):
    """Four stacked panels against time; returns the figure (saved at 200 dpi
    when path is given). run: RunData, a client Run or a dict of channels.
    metrics: sim.metrics(run) (tribo-fit metrics) to write each scratch's
    steady friction and µ on the figure."""
    import matplotlib
    if path is not None and matplotlib.get_backend().lower() not in ("agg", "module://matplotlib_inline.backend_inline"):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    samples = run.samples if hasattr(run, "samples") else run
    names = list(getattr(run, "segment_names", []) or [])
    t = samples["t"]
    friction_un = friction_n(samples) * 1e6
    mu = friction_coefficient(samples)

    fig, (ax_f, ax_mu, ax_n, ax_x) = plt.subplots(4, 1, sharex=True, figsize=(9, 9),
                                                   gridspec_kw={"height_ratios": [3, 2, 2, 2]})
    ax_f.plot(t, samples["lateral_force"] * 1e6, color="0.65", lw=0.5, label="lateral force (signed)")
    ax_f.plot(t, friction_un, color="C0", lw=0.8, label="friction (sliding)")
    ax_f.set_ylabel("force (µN)")
    ax_mu.plot(t, mu, color="C3", lw=0.8, label="µ = friction / normal force")
    ax_mu.set_ylabel("friction coefficient µ")
    finite = mu[np.isfinite(mu)]
    if finite.size:
        lo, hi = np.percentile(finite, [0.5, 99.5])
        pad = 0.1 * max(hi - lo, 1e-3)
        ax_mu.set_ylim(lo - pad, hi + pad)
    ax_n.plot(t, samples["normal_setpoint"] * 1e6, color="0.3", lw=0.8, ls="--", label="setpoint")
    ax_n.plot(t, samples["normal_force"] * 1e6, color="C2", lw=0.8, label="measured")
    ax_n.set_ylabel("normal force (µN)")
    ax_x.plot(t, samples["lateral_setpoint"] * 1e6, color="0.3", lw=0.8, ls="--", label="setpoint")
    ax_x.plot(t, samples["lateral_position"] * 1e6, color="C1", lw=0.8, label="measured")
    ax_x.set_ylabel("lateral position (µm)")
    ax_x.set_xlabel("time (s)")
    for ax in (ax_f, ax_mu, ax_n, ax_x):
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
        ax.grid(True, lw=0.3, color="0.85")
    spans = segment_spans(samples, names)
    _shade_segments((ax_f, ax_mu, ax_n, ax_x), spans, ax_f, float(t[-1] - t[0]) if len(t) else 0.0)
    if metrics:
        _annotate_scratches(ax_f, ax_mu, spans, metrics.get("scratches", []))
    if title is None:
        parts = [p for p in (getattr(run, "run_id", ""), getattr(run, "protocol_name", ""),
                             getattr(run, "exit_status", None)) if p]
        title = ", ".join(str(p) for p in parts)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    if path is not None:
        fig.savefig(path, dpi=DPI, bbox_inches="tight")
    return fig
