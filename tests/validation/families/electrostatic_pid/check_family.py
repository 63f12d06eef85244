#!/usr/bin/python3
"""Measurements behind the figures in README.md (slow: minutes; not a unit test).

    check_family.py loop FIRST LAST          stability, noise floors, lag, overshoot, time
    check_family.py contrib EFFECTS SEEDS    each effect's contribution to the recorded force
    check_family.py convergence SEEDS        recorded force against the plant sub-step
    check_family.py plot EFFECT SEED T0 T1 OUT.png   the effect's file against `none`

EFFECTS and SEEDS are comma-separated (EFFECTS may be `all`).
"""

import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import generate as G  # noqa: E402


def hold_segments(rec, pad_s=0.3, min_s=0.2):
    """Sample ranges where the setpoint has been still for pad_s and stays so for pad_s."""
    fs = rec["truth"]["rate_hz"]
    xr = rec["x_ref"]
    moving = np.abs(np.diff(xr, prepend=xr[0])) > 1e-13
    pad = int(pad_s * fs)
    near = np.convolve(moving.astype(float), np.ones(2 * pad + 1), "same") > 0
    segs, i = [], 0
    while i < len(xr):
        if near[i]:
            i += 1
            continue
        j = i
        while j < len(xr) and not near[j]:
            j += 1
        if j - i > min_s * fs:
            segs.append((i, j))
        i = j
    return segs


def high_pass_rms(signal, segs, width):
    parts = []
    for i, j in segs:
        if j - i <= 3 * width:
            continue
        s = signal[i:j]
        parts.append((s - np.convolve(s, np.ones(width) / width, "same"))[width:-width])
    return float(np.concatenate(parts).std() * np.sqrt(width / (width - 1)))


def overshoots(rec, min_speed=2e-6, window_s=0.5, min_rest_s=0.2, min_stroke_s=0.3):
    """Peak tip speed within window_s of each motion start after a rest of at least
    min_rest_s, over the largest commanded speed in that window (noise-free record)."""
    t, fs = rec["t"], rec["truth"]["rate_hz"]
    v = rec["sim"]["v_true"]
    vr = np.gradient(rec["x_ref"], t)
    moving = np.abs(vr) > 1e-8
    out = []
    for i in np.where(moving[1:] & ~moving[:-1])[0] + 1:
        j = i - 1
        while j > 0 and not moving[j]:
            j -= 1
        k = i
        while k < len(t) and moving[k] and np.sign(vr[k]) == np.sign(vr[i]):
            k += 1
        if (i - j) / fs < min_rest_s or (k - i) / fs < min_stroke_s:
            continue
        w = slice(i, min(k, i + int(window_s * fs)))
        v0 = np.max(np.abs(vr[w]))
        if v0 >= min_speed:
            out.append(float(np.max(np.sign(vr[i]) * v[w]) / v0))
    return out


def check_loop(first, last):
    for seed in range(first, last + 1):
        t0 = time.time()
        rec = G.make_record("none", seed)
        elapsed = time.time() - t0
        clean = G.make_record("none", seed, noise=False)
        tr = rec["truth"]
        lp = tr["loop"]
        segs = hold_segments(rec)
        width = max(int(0.02 * tr["rate_hz"]), 3)
        ov = overshoots(clean)
        row = {
            "seed": seed, "rate_hz": tr["rate_hz"], "controller_hz": lp["controller_rate_hz"],
            "duration_s": round(tr["protocol"]["duration_s"], 1),
            "generation_s": round(elapsed, 1), "diverged": rec["sim"]["diverged_at_tick"],
            "kp": round(lp["kp_n_per_m"]), "ki": round(lp["ki_n_per_m_s"]),
            "kd": round(lp["kd_n_s_per_m"], 2), "b": round(lp["setpoint_weight_b"], 2),
            "mass_g": round(lp["plant"]["mass_kg"] * 1e3, 2),
            "pole_damping": round(lp["min_pole_damping_ratio"], 3),
            "gain_margin": round(lp["gain_margin"], 2), "phase_margin": round(lp["phase_margin_deg"]),
            "x_noise_nm": round((rec["x"] - rec["sim"]["x_true"]).std() * 1e9, 2),
            "force_noise_rest_uN": round(high_pass_rms(rec["force"], segs, width) * 1e6, 1),
            "loop_force_noise_rest_uN": round(high_pass_rms(rec["sim"]["force_clean"], segs,
                                                            width) * 1e6, 1),
            "normal_noise_uN": round((rec["normal"] - rec["design"]["n_true"][
                ::lp["controller_rate_hz"] // tr["rate_hz"]]).std() * 1e6, 3),
            "lag_max_um": round(np.abs(rec["x_ref"] - rec["sim"]["x_true"]).max() * 1e6, 2),
            "overshoot_median": round(float(np.median(ov)), 2) if ov else None,
            "overshoot_max": round(float(np.max(ov)), 2) if ov else None,
            "loads_mN": [round(v * 1e3, 2) for v in tr["protocol"]["loads_n"]],
        }
        print(json.dumps(row), flush=True)


def check_contrib(effects, seeds, strength=None):
    """Recorded force of the effect's file minus that of `none`, same seed: both share every
    noise stream, so the readout noise cancels and what remains is the effect as the noisy
    loop transmits it (drift included)."""
    base = {s: G.make_record("none", s) for s in seeds}
    for eff in effects:
        for s in seeds:
            t0 = time.time()
            rec = G.make_record(eff, s, strength=strength)
            d = rec["force"] - base[s]["force"]
            aff = np.abs(d) > 5e-6
            print(json.dumps({
                "effect": eff, "seed": s, "generation_s": round(time.time() - t0, 1),
                "rms_affected_uN": round(float(np.sqrt(np.mean(d[aff] ** 2))) * 1e6, 1)
                if aff.any() else 0.0,
                "affected_share": round(float(aff.mean()), 3),
                "rms_all_uN": round(float(np.sqrt(np.mean(d ** 2))) * 1e6, 1),
                "diverged": rec["sim"]["diverged_at_tick"]}), flush=True)


def check_convergence(seeds):
    steps = [2.5e-5, 1.25e-5, 6.25e-6]
    for s in seeds:
        recs = {h: G.make_record("none", s, noise=False, max_substep=h, quantise=False)
                for h in steps}
        ref = recs[steps[-1]]
        for h in steps[:-1]:
            d = recs[h]["force"] - ref["force"]
            print(json.dumps({
                "seed": s, "substep_s": h, "against_s": steps[-1],
                "force_diff_rms_uN": round(float(np.sqrt(np.mean(d ** 2))) * 1e6, 3),
                "force_diff_q999_uN": round(float(np.quantile(np.abs(d), 0.999)) * 1e6, 2),
                "force_diff_max_uN": round(float(np.abs(d).max()) * 1e6, 2)}), flush=True)


def plot(effect, seed, t0, t1, out):
    """The effect's record and `none`'s (same seed, so the same noise), their difference."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    a = G.make_record(effect, seed)
    b = G.make_record("none", seed)
    t = a["t"]
    s = (t >= t0) & (t <= t1)
    fig, ax = plt.subplots(4, 1, figsize=(14, 11), sharex=True)
    ax[0].plot(t[s], a["x_ref"][s] * 1e6, "k", lw=0.8, label="x_ref")
    ax[0].plot(t[s], a["x"][s] * 1e6, "r", lw=0.6, label=effect + " recorded x")
    ax[0].plot(t[s], b["x"][s] * 1e6, "b--", lw=0.6, label="none recorded x")
    ax[0].set_ylabel("µm")
    ax[0].legend()
    ax[1].plot(t[s], a["force"][s] * 1e6, "r", lw=0.3, label=effect)
    ax[1].plot(t[s], b["force"][s] * 1e6, "b", lw=0.3, alpha=0.6, label="none")
    ax[1].set_ylabel("recorded force µN")
    ax[1].legend()
    ax[2].plot(t[s], (a["force"][s] - b["force"][s]) * 1e6, "k", lw=0.5)
    ax[2].set_ylabel("effect - none µN")
    ax[3].plot(t[s], a["normal"][s] * 1e3, "k", lw=0.6)
    ax[3].set_ylabel("normal mN")
    ax[3].set_xlabel("t s")
    plt.tight_layout()
    plt.savefig(out, dpi=70)


def main():
    cmd = sys.argv[1]
    if cmd == "loop":
        check_loop(int(sys.argv[2]), int(sys.argv[3]))
    elif cmd == "contrib":
        effects = G.EFFECTS[1:] if sys.argv[2] == "all" else sys.argv[2].split(",")
        strength = float(sys.argv[4]) if len(sys.argv) > 4 else None
        check_contrib(effects, [int(v) for v in sys.argv[3].split(",")], strength)
    elif cmd == "convergence":
        check_convergence([int(v) for v in sys.argv[2].split(",")])
    elif cmd == "plot":
        plot(sys.argv[2], int(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5]), sys.argv[6])
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main()
