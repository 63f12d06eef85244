"""Figures of a run for a lab notebook: friction and the friction coefficient
µ while sliding, the normal force, the lateral position against its setpoint;
µN, µm and s on the axes; segments shaded and named where the names fit;
legends beside the axes, never over the data; 200 dpi PNG.

Friction is plotted as what it is while sliding: the lateral force against
the commanded motion, positive in either direction. Just after a reversal
the lateral force still points the old way (the contact's deflection has not
yet reversed): the tip is not sliding the new way yet, and friction is not
drawn there (the signed lateral force is, in grey).

    from tribo_client import read_run, plots
    fig = plots.plot_run(read_run("runs/RUN_ID"), "run.png")
"""

import numpy as np

DPI = 200
# Sliding: the commanded lateral velocity beyond this (the validator's
# slowest allowed speed is 0.1 µm/s) under a positive normal setpoint.
MIN_SLIDING_SPEED_M_PER_S = 0.05e-6
# Labels on the figure keep this many pixels (at the figure's dpi) apart.
LABEL_GAP_PX = 4


def commanded_velocity_m_per_s(samples):
    t, x = samples["t"], samples["lateral_setpoint"]
    if len(t) < 2:
        return np.zeros_like(t)
    return np.gradient(x, t)


def friction_n(samples):
    """Friction while sliding: the lateral force against the commanded
    motion, positive in either direction; NaN where the tip is not sliding
    under load (no commanded motion, no load, or a lateral force that still
    points the way of the last motion, just after a reversal)."""
    v = commanded_velocity_m_per_s(samples)
    against = samples["lateral_force"] * np.sign(v)
    sliding = (np.abs(v) > MIN_SLIDING_SPEED_M_PER_S) & (samples["normal_setpoint"] > 0) & (against > 0)
    return np.where(sliding, against, np.nan)


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


def _short_name(name):
    """'stroke (pass 2/6)' -> 'stroke'."""
    return name.split(" (")[0]


def place_labels(ax, renderer, labels, rows, **text_kwargs):
    """Writes each label at x (data) on one of `rows` (y in axes fractions)
    where it overlaps no label already placed. labels: [(x, [text, shorter
    text, ...])], all with as many forms: the longest form that lets every
    label find a place is used for all; with the shortest, a label without a
    place is left out. Returns the texts placed."""
    forms = min(len(texts) for _, texts in labels) if labels else 0
    for form in range(forms):
        placed, boxes = [], []
        for x, texts in labels:
            for y in rows:
                artist = ax.text(x, y, texts[form], transform=ax.get_xaxis_transform(), clip_on=False,
                                 **text_kwargs)
                box = artist.get_window_extent(renderer).padded(LABEL_GAP_PX / 2)
                if not any(box.overlaps(other) for other in boxes):
                    placed.append(artist)
                    boxes.append(box)
                    break
                artist.remove()
        if len(placed) == len(labels) or form == forms - 1:
            return placed
        for artist in placed:
            artist.remove()
    return []


def _shade_segments(axes, spans):
    for k, (_, _, begin, end) in enumerate(spans):
        if k % 2:
            for ax in axes:
                ax.axvspan(begin, end, color="0.93", lw=0, zorder=0)


def _name_segments(ax, renderer, spans):
    """Each segment's index and name over its middle, shortened ('2: stroke',
    then '2') or left out where it would overlap its neighbour's."""
    labels = [((begin + end) / 2, [f"{index}: {name}", f"{index}: {_short_name(name)}", f"{index}"])
              for index, name, begin, end in spans]
    return place_labels(ax, renderer, labels, rows=(1.02,), ha="center", va="bottom", fontsize=7)


def _annotate_scratches(ax_f, ax_mu, renderer, spans, scratches):
    """The steady mean friction and µ of each loaded sliding segment (the
    scratch metrics of tribo-fit metrics), written over its segment on one of
    two rows, shortened or left out where they would overlap."""
    where = {index: (begin, end) for index, _, begin, end in spans}
    friction, mu = [], []
    for s in scratches:
        if s["segment"] not in where:
            continue
        middle = sum(where[s["segment"]]) / 2
        value = s["mean_friction_n"] * 1e6
        friction.append((middle, [f"steady friction {value:.1f} µN", f"{value:.1f} µN"]))
        mu.append((middle, [f"steady µ = {s['mu']:.4f}", f"{s['mu']:.4f}"]))
    backing = {"facecolor": "white", "edgecolor": "none", "alpha": 0.8, "pad": 1}  # legible over the curves
    place_labels(ax_f, renderer, friction, rows=(0.04, 0.14), ha="center", fontsize=8, color="C0", bbox=backing)
    place_labels(ax_mu, renderer, mu, rows=(0.06, 0.18), ha="center", fontsize=8, color="C3", bbox=backing)


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
    ax_f.plot(t, samples["lateral_force"] * 1e6, color="0.65", lw=0.5, label="lateral force\n(+ towards +x)")
    ax_f.plot(t, friction_un, color="C0", lw=0.8, label="friction while sliding\n(against the motion)")
    ax_f.set_ylabel("force (µN)")
    ax_mu.plot(t, mu, color="C3", lw=0.8, label="µ = friction /\nnormal force")
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
    _shade_segments((ax_f, ax_mu, ax_n, ax_x), spans)
    if title is None:
        parts = [p for p in (getattr(run, "run_id", ""), getattr(run, "protocol_name", ""),
                             getattr(run, "exit_status", None)) if p]
        title = ", ".join(str(p) for p in parts)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    # Labels last, on the final layout: their extents decide which fit.
    renderer = fig.canvas.get_renderer()
    _name_segments(ax_f, renderer, spans)
    if metrics:
        _annotate_scratches(ax_f, ax_mu, renderer, spans, metrics.get("scratches", []))
    if path is not None:
        fig.savefig(path, dpi=DPI, bbox_inches="tight")
    return fig
