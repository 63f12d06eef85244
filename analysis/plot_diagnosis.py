#!/usr/bin/python3
"""Plots of a tribo-fit diagnosis (tribo-fit diagnose ... --out DIR).

    /usr/bin/python3 analysis/plot_diagnosis.py DIR [--title TEXT] [--zoom T0 T1]

Writes into DIR:
  before_after.png   measured force with the model before and after the accepted
                     effects, over the whole record and a zoomed window, and the
                     residuals; held-out passes shaded
  hysteresis.png     force against position (measured, before, after)
  signature_<effect>.png  for each accepted effect (and each fitted but
                     rejected one): the residual against the regressor that
                     revealed it, as the diagnosis measured it on the fit data,
                     in the input's force unit; points (passes, bins) in
                     markers sorted along x, a spectrum as a curve
Needs numpy and matplotlib (Debian python3-numpy, python3-matplotlib).
"""
import argparse
import csv
import json
import os
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


DPI = 200

# SI prefixes for readable axes: forces in uN or mN, lengths in um or mm, etc.
# A signature's residual is in the input's force unit (N, or e.g. Pa), its
# power in that unit squared.
PREFIXES = [(1e-9, "n"), (1e-6, "\u00b5"), (1e-3, "m"), (1.0, ""), (1e3, "k"), (1e6, "M"), (1e9, "G")]


def scaled(values, unit):
    """(factor, label): values * factor shown in a prefixed unit (N -> uN, m -> um, Pa -> MPa)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    typical = np.percentile(np.abs(v), 95) if v.size else 1.0
    if not unit or unit in ("1",) or typical == 0:
        return 1.0, unit
    best = PREFIXES[3]
    for factor, prefix in PREFIXES:
        if typical >= factor:
            best = (factor, prefix)
    return 1.0 / best[0], best[1] + unit


def wrap(text, width=100):
    return "\n".join(textwrap.wrap(text, width))


def read_traces(path):
    data = np.genfromtxt(path, delimiter=",", names=True)
    return data


def read_signatures(path):
    groups = {}
    if not os.path.exists(path):
        return groups
    with open(path) as f:
        for row in csv.DictReader(f):
            key = (row["effect"], row["stage"])
            g = groups.setdefault(key, {"x_label": row["x_label"], "y_label": row["y_label"], "x": [], "y": [], "e": []})
            g["x"].append(float(row["x"]) if row["x"] else np.nan)
            g["y"].append(float(row["y"]) if row["y"] else np.nan)
            g["e"].append(float(row["y_error"]) if row["y_error"] else np.nan)
    return groups


def shade_heldout(ax, t, heldout):
    edges = np.flatnonzero(np.diff(np.r_[0, heldout.astype(int), 0]))
    for start, stop in zip(edges[::2], edges[1::2]):
        ax.axvspan(t[start], t[min(stop, len(t) - 1)], color="0.9", lw=0)


def plot_before_after(d, report, out, title, zoom):
    t = d["t_s"]
    k, unit = scaled(d["force"], report["input"]["force_unit"])
    f, before, after = k * d["force"], k * d["model_before"], k * d["model_after"]
    effects = ", ".join(e["name"] for e in report["accepted_effects"]) or "none"
    # With --base-model choose the model after is the contact kept, with the effects.
    contact = report.get("base_model", {}).get("contact_choice", {}).get("chosen", "lugre")
    after_label = (f"contact {contact}, " if contact != "lugre" else "") + f"with {effects} (after)"
    eb, ea = report["error_before"]["heldout"], report["error_after"]["heldout"]
    fig, axes = plt.subplots(3, 1, figsize=(11, 9), constrained_layout=True)
    for ax in axes[:2]:
        shade_heldout(ax, t, d["heldout"])
    axes[0].plot(t, f, color="k", lw=0.6, label="measured")
    axes[0].plot(t, before, color="tab:blue", lw=0.8, label="LuGre (before)")
    axes[0].plot(t, after, color="tab:red", lw=0.8, ls="--", label=after_label)
    axes[0].set_ylabel(f"force ({unit})")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title(wrap(f"{title}: {'contact ' + contact + ', ' if contact != 'lugre' else ''}accepted {effects}. Held-out RMS {k * eb['rms']:.4g} -> {k * ea['rms']:.4g} {unit} "
                           f"(relative {100 * eb['relative']:.2f} % -> {100 * ea['relative']:.2f} %); held-out passes shaded"),
                      fontsize=11)
    axes[1].plot(t, f - before, color="tab:blue", lw=0.5, label="residual before")
    axes[1].plot(t, f - after, color="tab:red", lw=0.5, alpha=0.8, label="residual after")
    axes[1].set_ylabel(f"residual ({unit})")
    axes[1].legend(loc="upper right", fontsize=8)
    if zoom is None:
        n = len(t)
        zoom = (t[int(0.45 * n)], t[min(n - 1, int(0.55 * n))])
    sel = (t >= zoom[0]) & (t <= zoom[1])
    axes[2].plot(t[sel], f[sel], color="k", lw=0.8, label="measured")
    axes[2].plot(t[sel], before[sel], color="tab:blue", lw=1, label="before")
    axes[2].plot(t[sel], after[sel], color="tab:red", lw=1, ls="--", label="after")
    axes[2].set_xlabel("time (s)")
    axes[2].set_ylabel(f"force ({unit}), zoom")
    axes[2].legend(loc="upper right", fontsize=8)
    fig.savefig(os.path.join(out, "before_after.png"), dpi=DPI)
    plt.close(fig)


def plot_hysteresis(d, report, out, title):
    k, unit = scaled(d["force"], report["input"]["force_unit"])
    kx, xunit = scaled(d["position_m"], "m")
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), constrained_layout=True, sharey=True)
    for ax, model, label in ((axes[0], "model_before", "before"), (axes[1], "model_after", "after")):
        ax.plot(kx * d["position_m"], k * d["force"], color="k", lw=0.4, label="measured")
        ax.plot(kx * d["position_m"], k * d[model], color="tab:red" if label == "after" else "tab:blue", lw=0.6, label=f"model {label}")
        ax.set_xlabel(f"position ({xunit})")
        ax.set_title(f"model {label} the diagnosis", fontsize=10)
        ax.legend(fontsize=8)
    axes[0].set_ylabel(f"force ({unit})")
    fig.suptitle(wrap(f"{title}: force against position"), fontsize=11)
    fig.savefig(os.path.join(out, "hysteresis.png"), dpi=DPI)
    plt.close(fig)


def signature_y_unit(y_label, force_unit):
    """The unit of a signature's residual axis: the force unit of the input,
    squared for a power; the C++ labels name the quantity only."""
    if "power" in y_label:
        return f"{force_unit}\u00b2"
    if "residual" in y_label:
        return force_unit
    return ""


def signature_axes(g, force_unit):
    """(x, y, y_error, x label, y label): sorted by x, in prefixed units
    (m -> um, N -> uN), each label with its unit."""
    x, y, e = np.array(g["x"]), np.array(g["y"]), np.array(g["e"])
    order = np.argsort(x, kind="stable")  # points in the order of the axis, never the record's
    x, y, e = x[order], y[order], e[order]
    xl, yl = g["x_label"], g["y_label"]
    if "(m)" in xl:
        kx, u = scaled(x, "m")
        x, xl = kx * x, xl.replace("(m)", f"({u})")
    unit = signature_y_unit(yl, force_unit)
    if unit.endswith("\u00b2"):  # a power: in the unit squared, unprefixed ((mN)^2 reads badly)
        yl = f"{yl} ({unit})"
    elif unit:
        ky, u = scaled(y, unit)
        y, e, yl = ky * y, ky * e, f"{yl} ({u})"
    return x, y, e, xl, yl


def signature_figure(effect, stage, g, force_unit, verdict):
    """The figure of one signature (g: a read_signatures group)."""
    fig, ax = plt.subplots(figsize=(7, 4.2), constrained_layout=True)
    x, y, e, xl, yl = signature_axes(g, force_unit)
    # A spectrum is a curve; every other signature is a set of points (passes, bins): markers.
    style = {"fmt": "-", "lw": 0.8} if "wavelength" in xl else {"fmt": "o", "ms": 3}
    if np.all(np.isnan(e)):
        ax.plot(x, y, style["fmt"], **{k: v for k, v in style.items() if k != "fmt"})
    else:
        ax.errorbar(x, y, yerr=e, capsize=2, elinewidth=0.6, **style)
    if "wavelength" in xl or "speed" in xl:
        ax.set_xscale("log")
    ax.axhline(0, color="0.5", lw=0.6)
    ax.set_xlabel(xl)
    ax.set_ylabel(wrap(yl, 45))
    ax.set_title(wrap(f"{effect} ({stage}): {verdict}", 110), fontsize=7, loc="left")
    return fig


def plot_signatures(groups, report, out):
    verdicts = {e["name"]: ("accepted", e.get("signature", "")) for e in report["accepted_effects"]}
    for e in report["rejected_effects"]:
        verdicts.setdefault(e["name"], ("rejected", e.get("reason", "")))
    force_unit = report["input"].get("force_unit", "N")
    for (effect, stage), g in groups.items():
        fig = signature_figure(effect, stage, g, force_unit, verdicts.get(effect, (stage, ""))[1])
        fig.savefig(os.path.join(out, f"signature_{effect}.png"), dpi=DPI)
        plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dir")
    parser.add_argument("--title", default=None)
    parser.add_argument("--zoom", nargs=2, type=float, default=None)
    args = parser.parse_args()
    with open(os.path.join(args.dir, "diagnosis.json")) as f:
        report = json.load(f)
    d = read_traces(os.path.join(args.dir, "traces.csv"))
    title = args.title or os.path.basename(report["input"]["source"])
    plot_before_after(d, report, args.dir, title, args.zoom)
    plot_hysteresis(d, report, args.dir, title)
    plot_signatures(read_signatures(os.path.join(args.dir, "signatures.csv")), report, args.dir)


if __name__ == "__main__":
    main()
