"""docs/friction_compensation.md's figure: two recorded runs of
config/protocols/breakaway_velocities.textproto, without and with the friction
compensation: the tip's velocity after each break-away (the least-squares
slope of the recorded position over a centred 10 ms window, over the
commanded velocity), the position error at the reversals, and the lateral
force the transducer reads (the friction the record reports).

usage: /usr/bin/python3 docs/figures/make_friction_compensation_figure.py BEFORE_DIR AFTER_DIR OUT.png
BEFORE_DIR and AFTER_DIR are run folders (metadata.json, samples.csv) from `tribo run --out`.
"""
import csv
import json
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


def read(run_dir):
    rows = list(csv.reader(open(f"{run_dir}/samples.csv")))
    head, data = rows[0], np.array(rows[1:], dtype=float)
    col = {name: data[:, i] for i, name in enumerate(head)}
    meta = json.load(open(f"{run_dir}/metadata.json"))
    return col, meta["start"]["segments"]


def velocity(t, x, half=5):
    """Least-squares slope over 2 half + 1 samples (10 ms of the 1 kHz record)."""
    v = np.zeros_like(x)
    for i in range(len(x)):
        lo, hi = max(0, i - half), min(len(x), i + half + 1)
        tt, xx = t[lo:hi] - t[lo:hi].mean(), x[lo:hi] - x[lo:hi].mean()
        v[i] = (tt * xx).sum() / (tt * tt).sum()
    return v


before_dir, after_dir, out = sys.argv[1], sys.argv[2], sys.argv[3]
runs = {"without compensation": read(before_dir), "with compensation": read(after_dir)}
styles = {"without compensation": dict(color="tab:red", lw=0.9), "with compensation": dict(color="tab:blue", lw=0.9)}

fig = plt.figure(figsize=(10, 7.2))
grid = fig.add_gridspec(3, 3, height_ratios=[1.1, 1, 1])
for k in range(3):
    ax = fig.add_subplot(grid[0, k])
    for label, (col, segments) in runs.items():
        slides = [i for i, s in enumerate(segments) if s["name"].startswith("slide")]
        seg = slides[k]
        m = col["segment_index"] == seg
        t, x, sp = col["t_s"][m], col["lateral_position_m"][m], col["lateral_setpoint_m"][m]
        commanded = (sp[-1] - sp[0]) / (t[-1] - t[0])
        v = velocity(t, x) / commanded
        ax.plot(t - segments[seg]["start_s"], v, label=f"{label}: peak {v.max():.2f}x", **styles[label])
        ax.set_title(f"break-away at {commanded * 1e6:.0f} µm/s, 9810 µN", fontsize=9)
    ax.axhline(1.3, color="grey", lw=0.6, ls="--")
    ax.set_xlim(0, 0.6 if k == 0 else 0.3)
    ax.set_xlabel("time from the ramp's start (s)")
    if k == 0:
        ax.set_ylabel("tip velocity / commanded")
    ax.legend(fontsize=7, loc="upper right")

ax = fig.add_subplot(grid[1, :])
for label, (col, segments) in runs.items():
    strokes = [i for i, s in enumerate(segments) if s["name"].startswith("stroke")]
    m = np.isin(col["segment_index"], strokes)
    t = col["t_s"][m]
    err = (col["lateral_setpoint_m"][m] - col["lateral_position_m"][m]) * 1e6
    ax.plot(t - t[0], err, **styles[label], label=label)
ax.set_ylabel("setpoint - position (µm)")
ax.set_xlabel("time from the first stroke (s): four strokes of 10 µm at 4 µm/s, 9810 µN")
ax.legend(fontsize=8)

ax = fig.add_subplot(grid[2, :])
for label, (col, segments) in runs.items():
    strokes = [i for i, s in enumerate(segments) if s["name"].startswith("stroke")]
    m = np.isin(col["segment_index"], strokes)
    t = col["t_s"][m]
    ax.plot(t - t[0], col["lateral_force_N"][m] * 1e6, **styles[label], label=label)
ax.set_ylabel("lateral force read (µN)")
ax.set_xlabel("time from the first stroke (s)")
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(out, dpi=120)
