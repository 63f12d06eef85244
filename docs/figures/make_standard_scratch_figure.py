"""The README's figure: friction and mu of the standard scratch as `scripts/demo` records it.

usage: /usr/bin/python3 docs/figures/make_standard_scratch_figure.py RUN_DIR OUT.png
RUN_DIR is a run folder (metadata.json, samples.csv) from `tribo run --out` or `tribo fetch`.
"""
import csv
import json
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

run_dir, out = sys.argv[1], sys.argv[2]
rows = list(csv.reader(open(f"{run_dir}/samples.csv")))
head, data = rows[0], np.array(rows[1:], dtype=float)
col = {name: i for i, name in enumerate(head)}
# Column names differ between versions (t_s / time_s ...): take them by their prefix.
def column(prefix):
    return data[:, next(i for name, i in col.items() if name.startswith(prefix))]
t, seg = column("t"), column("segment").astype(int)
normal, lateral_force = column("normal_force"), column("lateral_force")
setpoint = column("lateral_setpoint")
meta = json.load(open(f"{run_dir}/metadata.json"))
names = [s["name"] for s in meta["start"].get("segments", [])] or [s["name"] for s in meta["start"]["protocol"]["segments"]]

# Friction: the lateral force along the commanded motion.
direction = np.sign(np.gradient(setpoint))
friction_un = direction * lateral_force * 1e6
sliding = (normal > 100e-6) & (direction != 0)  # loaded and moving: friction is defined

fig, (ax_f, ax_n) = plt.subplots(2, 1, sharex=True, figsize=(8, 4.8), gridspec_kw={"height_ratios": [2, 1]})
ax_f.plot(t, np.where(sliding, friction_un, np.nan), lw=0.6, color="tab:blue")
ax_f.set_ylabel("friction (µN)")
ax_mu = ax_f.twinx()
lo, hi = ax_f.get_ylim()
load_un = np.mean(normal[sliding]) * 1e6  # µ = friction / normal force on the right axis
ax_mu.set_ylim(lo / load_un, hi / load_un)
ax_mu.set_ylabel(f"µ at {load_un:.1f} µN")
ax_n.plot(t, normal * 1e6, lw=0.8, color="tab:gray")
ax_n.set_ylabel("normal force (µN)")
ax_n.set_xlabel("time (s)")
for k in np.unique(seg):
    ts = t[seg == k]
    for ax in (ax_f, ax_n):
        ax.axvline(ts[0], color="0.8", lw=0.6, zorder=0)
    ax_n.text((ts[0] + ts[-1]) / 2, 0.92, names[k] if k < len(names) else str(k), transform=ax_n.get_xaxis_transform(),
              ha="center", va="top", fontsize=8)
ax_f.set_title(f"standard scratch on the simulated instrument ({meta['start']['run_id']}, seed {meta['start']['seed']})",
               fontsize=9)
for ax in (ax_f, ax_n):
    ax.grid(alpha=0.3)
fig.tight_layout()
fig.savefig(out, dpi=200)
