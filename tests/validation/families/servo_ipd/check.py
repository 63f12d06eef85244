#!/usr/bin/env python3
"""Measures the servo_ipd generator's figures quoted in README.md (not a test: it prints).

  check.py loop SEEDS              loop draws, stability, lag, break-away, record noise (clean)
  check.py contributions SEEDS     each effect's contribution to the recorded force
  check.py steady SEEDS            steady sliding friction against the law's F_ss(v) (clean)
  check.py convergence SEED        integration error against a finer substep
  check.py plot EFFECT SEED DIR    a figure of the record (with the clean record of the seed)

SEEDS: a list like 1-20 or 1,2,3.
"""

import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import generate as g  # noqa: E402


def _seeds(text):
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def _ref_speed(rec):
    return np.append(np.diff(rec["x_ref"]) / np.diff(rec["t"]), 0.0)


def _noise_floors(rec):
    vr = _ref_speed(rec)
    hold = (vr == 0.0)
    h = hold[1:] & hold[:-1]
    sx = np.std(np.diff(rec["x"])[h]) / np.sqrt(2.0)
    sf = np.std(np.diff(rec["force"])[h]) / np.sqrt(2.0)
    return sx, sf


def _breakaways(b, rec):
    """Strokes starting from a hold of >= 0.5 s at one speed for >= 0.3 s: the friction peak
    over the late sliding level and the tip's peak speed over the commanded one."""
    t, rate = rec["t"], b["rate_hz"]
    vr = _ref_speed(rec)
    out = []
    starts = np.where((vr[1:] != 0.0) & (vr[:-1] == 0.0))[0] + 1
    for i0 in starts:
        if i0 < int(0.5 * rate) or np.any(vr[i0 - int(0.5 * rate):i0] != 0.0):
            continue
        v0 = vr[i0]
        n = 0
        while i0 + n < len(vr) and abs(vr[i0 + n] - v0) <= 1e-3 * abs(v0) and n < 3 * rate:
            n += 1
        if n < 0.3 * rate:
            continue
        f = np.abs(rec["friction_true"][i0:i0 + n])
        v = np.abs(rec["v_true"][i0:i0 + n])
        late = f[int(0.6 * n):].mean()
        out.append((abs(v0), f.max() / late, v.max() / abs(v0)))
    return out


def cmd_loop(seeds):
    print("seed fc_Hz rate_Hz kp ki kd ta_ms zeta_contact loopF_uN dither_um/s vs_um/s "
          "dur_s gen_s maxlag_um steadylag_um(v) x_noise_nm F_noise_uN breakaways(v0 peak vmax/v0)")
    allb = []
    for s in seeds:
        t0 = time.time()
        b, rec = g.run("none", s, traces=True)
        dt = time.time() - t0
        L, c = b["loop"], b["contact"]
        vr = _ref_speed(rec)
        err = rec["x_ref"] - rec["x_true"]
        vmax = np.abs(vr).max()
        fast = np.abs(np.abs(vr) - vmax) < 1e-3 * vmax
        # steady lag: the last 30 % of the samples at the fastest speed
        idx = np.where(fast)[0]
        steady = np.median(np.abs(err[idx[int(0.7 * len(idx)):]])) if len(idx) else np.nan
        sx, sf = _noise_floors(rec)
        ba = _breakaways(b, rec)
        allb += ba
        print("%2d %5d %4d %4.0f %4.0f %.2f %.2f %.2f %.1f %.2f %.2f %3.0f %4.1f %.2f %.2f(%.0f) "
              "%.1f %.1f %s" % (
                  s, L["controller_rate_hz"], b["rate_hz"], L["kp_n_per_m"], L["ki_n_per_m_s"],
                  L["kd_n_s_per_m"], L["actuator_lag_s"] * 1e3,
                  L["min_mode_damping_ratio_in_contact"], L["loop_force_noise_n"] * 1e6,
                  L["tip_speed_dither_m_per_s"] * 1e6, c["vs_m_per_s"] * 1e6,
                  b["protocol"]["duration_s"], dt, np.abs(err).max() * 1e6, steady * 1e6,
                  vmax * 1e6, sx * 1e9, sf * 1e6,
                  " ".join("(%.1f %.2f %.1f)" % (v * 1e6, p, o) for v, p, o in ba)))
        sys.stdout.flush()
    if allb:
        a = np.array(allb)
        print("break-aways: %d; friction peak/sliding median %.2f (max %.2f); tip speed "
              "peak/commanded median %.1f (10-90 %%: %.1f-%.1f)" % (
                  len(a), np.median(a[:, 1]), a[:, 1].max(), np.median(a[:, 2]),
                  np.percentile(a[:, 2], 10), np.percentile(a[:, 2], 90)))


def cmd_contributions(seeds, effects=None):
    """The effect's contribution: the file's force minus the clean file's force of the same
    seed (same loop, contact, protocol and noise), RMS over the samples where it exceeds 5 µN
    (above the 3 µN quantum) and over all samples."""
    effects = effects or g.EFFECTS[1:]
    base = {s: g.run("none", s)[1]["force"] for s in seeds}
    print("effect strength | per seed: RMS over affected samples µN (share affected), RMS all")
    for e in effects:
        cells = []
        for s in seeds:
            b, rec = g.run(e, s)
            d = rec["force"] - base[s]
            aff = np.abs(d) > 5e-6
            ra = np.sqrt(np.mean(d[aff] ** 2)) * 1e6 if aff.any() else 0.0
            cells.append("%5.1f (%3.0f%%) %5.1f" % (ra, aff.mean() * 100,
                                                    np.sqrt(np.mean(d ** 2)) * 1e6))
        print("%-22s %-8g | %s" % (e, g.DEFAULT_STRENGTH[e], " | ".join(cells)))
        sys.stdout.flush()


def _simple_protocol(load_n):
    """Noise-free convergence protocol: at one load, strokes of 6 µm at 10 and 20 µm/s
    from rest, holds of 1 s between them."""
    t, x = [0.0, 1.0], [0.0, 0.0]
    sign = 1.0
    for v in (10e-6, 20e-6, 10e-6, 20e-6):
        t.append(t[-1] + 6e-6 / v)
        x.append(x[-1] + sign * 6e-6)
        t.append(t[-1] + 1.0)
        x.append(x[-1])
        sign = -sign
    return {"t_ref": np.array(t), "x_ref": np.array(x), "t_load": np.array([0.0, t[-1]]),
            "load": np.array([load_n, load_n]), "strokes": [], "duration_s": t[-1]}


def cmd_steady(seeds):
    """Mean true friction over the second half of each constant-speed segment of >= 0.5 s,
    against the LuGre steady state F_ss(v) = Fc + (Fs - Fc) exp(-(v/vs)^2) + Fv v at the
    commanded speed and the load: what the dither and any chatter do to the sliding level."""
    by_speed = {}
    for s in seeds:
        b, rec = g.run("none", s, traces=True)
        c, rate = b["contact"], b["rate_hz"]
        vr = _ref_speed(rec)
        i = 0
        while i < len(vr):
            j = i
            while j < len(vr) and abs(vr[j] - vr[i]) <= 1e-6 * abs(vr[i]) + 1e-15:
                j += 1
            v0 = abs(vr[i])
            if v0 > 0 and (j - i) >= 0.5 * rate:
                k = slice(i + (j - i) // 2, j)
                n = rec["normal"][k].mean()
                fss = (c["mu_c"] * n + (c["mu_s"] - c["mu_c"]) * n
                       * np.exp(-(v0 / c["vs_m_per_s"]) ** 2) + c["fv_n_s_per_m"] * v0)
                ratio = np.abs(rec["friction_true"][k]).mean() / fss
                level = min((1, 2.5, 6, 12, 20), key=lambda L: abs(np.log(v0 * 1e6 / L)))
                by_speed.setdefault(level, []).append(ratio)
            i = j
    for level in sorted(by_speed):
        r = np.array(by_speed[level])
        print("speed ~%4.1f µm/s: %3d segments, friction / F_ss median %.3f, 10-90 %% "
              "%.3f-%.3f" % (level, len(r), np.median(r), np.percentile(r, 10),
                             np.percentile(r, 90)))


def cmd_convergence(seed, effect="none"):
    """Integration error against a substep of 6.25 µs: noise-free on a simple protocol at
    1 and 8 mN with the seed's loop and contact (where the motion is not chaotic), and on
    the seed's own noisy record (where slip events at low speed move with any rounding)."""
    hs = (50e-6, 25e-6, 12.5e-6, 6.25e-6)
    b = g.build(effect, seed)
    for load in (1e-3, 8e-3):
        p = _simple_protocol(load)
        recs = {h: g.simulate(b["loop"], b["contact"], p, effect, b["effect_parameters"],
                              np.random.default_rng(0), noise=False, substep_s=h,
                              traces=True, record_rate_hz=b["rate_hz"]) for h in hs}
        ref = recs[hs[-1]]
        fs = b["contact"]["mu_s"] * load
        for h in hs[:-1]:
            d = recs[h]["friction_true"] - ref["friction_true"]
            print("%s seed %d noise-free, %.0f mN: substep %5.2f µs: friction error RMS %.4f µN, "
                  "max %.3f µN (%.1e Fs)" % (effect, seed, load * 1e3, h * 1e6,
                                             np.sqrt(np.mean(d ** 2)) * 1e6,
                                             np.abs(d).max() * 1e6, np.abs(d).max() / fs))
    recs = {h: g.run(effect, seed, substep_s=h, traces=True)[1] for h in hs}
    ref = recs[hs[-1]]
    for h in hs[:-1]:
        d = recs[h]["friction_true"] - ref["friction_true"]
        print("%s seed %d record with noise: substep %5.2f µs: friction error RMS %.3f µN, "
              "median %.4f µN, max %.1f µN" % (effect, seed, h * 1e6,
                                               np.sqrt(np.mean(d ** 2)) * 1e6,
                                               np.median(np.abs(d)) * 1e6, np.abs(d).max() * 1e6))


def cmd_plot(effect, seed, out_dir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    b, rec = g.run(effect, seed, traces=True)
    _, base = g.run("none", seed, traces=True)
    t = rec["t"]
    fig, ax = plt.subplots(4, 1, figsize=(13, 10), sharex=True)
    ax[0].plot(t, rec["x_ref"] * 1e6, "r-", lw=0.8, label="x_ref")
    ax[0].plot(t, rec["x"] * 1e6, "k-", lw=0.4, label="x recorded")
    ax[0].set_ylabel("µm")
    ax[0].legend(loc="upper right")
    ax[1].plot(t, (rec["x_ref"] - rec["x_true"]) * 1e6, lw=0.5)
    ax[1].set_ylabel("x_ref - x µm")
    ax[2].plot(t, rec["force"] * 1e6, "k-", lw=0.3, label="force recorded")
    ax[2].plot(t, rec["friction_true"] * 1e6, "c-", lw=0.5, label="friction (true)")
    ax[2].set_ylabel("µN")
    ax[2].legend(loc="upper right")
    if effect != "none":
        ax[3].plot(t, (rec["force"] - base["force"]) * 1e6, "b-", lw=0.4)
        ax[3].set_ylabel("force - clean µN")
    else:
        ax[3].plot(t, rec["normal"] * 1e3)
        ax[3].set_ylabel("normal mN")
    ax[3].set_xlabel("t s")
    fig.suptitle("servo_ipd %s seed %d" % (effect, seed))
    plt.tight_layout()
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, "servo_ipd_%s_seed%d.png" % (effect, seed))
    plt.savefig(path, dpi=70)
    print(path)


def main():
    if len(sys.argv) < 3:
        print(__doc__)
        sys.exit(2)
    cmd = sys.argv[1]
    if cmd == "loop":
        cmd_loop(_seeds(sys.argv[2]))
    elif cmd == "contributions":
        cmd_contributions(_seeds(sys.argv[2]), sys.argv[3].split(",") if len(sys.argv) > 3 else None)
    elif cmd == "steady":
        cmd_steady(_seeds(sys.argv[2]))
    elif cmd == "convergence":
        cmd_convergence(int(sys.argv[2]), sys.argv[3] if len(sys.argv) > 3 else "none")
    elif cmd == "plot":
        cmd_plot(sys.argv[2], int(sys.argv[3]), sys.argv[4])
    else:
        print(__doc__)
        sys.exit(2)


if __name__ == "__main__":
    main()
