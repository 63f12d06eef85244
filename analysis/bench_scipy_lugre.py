#!/usr/bin/python3
"""scipy's least_squares on tribo's LuGre fit problem: same model, same data, same start.

    build/bench/lugre_fit_export DIR            # writes DIR/problem.csv and DIR/tribo_fit.json
    /usr/bin/python3 analysis/bench_scipy_lugre.py DIR

The model is the base LuGre model of analysis/models/friction_model.cc, load-scaled,
exponential Stribeck shape, re-implemented here in plain Python (per-sample
loop, no compiled extension): the bristle state advanced exactly over each
sample interval at the interval's mean velocity, with the same sub-steps where
the velocity changes sign or by a quarter while the bristle relaxes fast. The
parameters are the same normalised thetas (log for the positive scales), and
least_squares ('trf', two-point finite-difference Jacobian, x_scale 'jac')
starts from the same point. Prints both fits' residual and wall time and their
ratio; writes DIR/scipy_fit.json.
"""
import json
import math
import os
import sys
import time

import numpy as np
from scipy.optimize import least_squares


def load(directory):
    data = np.genfromtxt(os.path.join(directory, "problem.csv"), delimiter=",", names=True)
    with open(os.path.join(directory, "tribo_fit.json")) as f:
        tribo = json.load(f)
    return data, tribo


def simulate(theta, specs, t, x, v, vstep, normal, force_scale):
    values = {}
    for th, s in zip(theta, specs):
        if s["transform"] == "log":
            values[s["name"]] = s["scale"] * math.exp(max(-40.0, min(40.0, th)))
        else:
            values[s["name"]] = s["scale"] * th
    mu_c, mu_s, vs = values["mu_c"], values["mu_s"], values["vs"]
    sigma0, sigma1, fv, offset = values["sigma0"], values["sigma1"], values["Fv"], values["offset"]
    tiny = 1e-9 * force_scale
    n = len(t)
    out = np.empty(n)
    exp = math.exp

    def level_at(speed, nn):
        if nn <= 0:
            return 0.0
        return nn * (mu_c + (mu_s - mu_c) * exp(-speed / vs))

    def step(z, vel, h, g):
        a = abs(vel) / g
        u = a * h
        if u < 1e-9:
            return z + vel * h
        e = exp(-u)
        return z * e + vel * (1.0 - e) / a

    level = level_at(abs(v[0]), normal[0])
    z = (1.0 if v[0] >= 0 else -1.0) * level / sigma0 if (v[0] != 0 and level > tiny) else 0.0
    for i in range(n):
        level_prev = level
        if i > 0:
            level = level_at(abs(v[i]), normal[i])
        if level <= tiny:
            z = 0.0
            out[i] = offset
            continue
        g = level / sigma0
        if i > 0:
            h = t[i] - t[i - 1]
            va, vb, mean = v[i - 1], v[i], vstep[i]
            start = level_prev if level_prev > tiny else level
            g_min = min(start, level) / sigma0
            rate = max(abs(va), abs(vb)) / max(g_min, 1e-300)
            steady = va * vb > 0 and abs(vb - va) <= 0.25 * max(abs(va), abs(vb))
            m = 1 if steady else min(16, max(1, int(math.ceil(rate * h / 0.5))))
            if m == 1:
                z = step(z, mean, h, 0.5 * (start + level) / sigma0)
            else:
                for k in range(m):
                    u = (k + 0.5) / m
                    vk = mean + (vb - va) * (u - 0.5)
                    lk = level_at(abs(vk), normal[i])
                    if lk <= tiny:
                        z = 0.0
                        break
                    z = step(z, vk, h / m, lk / sigma0)
        vi = v[i]
        dz = vi - abs(vi) * z / g
        out[i] = sigma0 * z + sigma1 * dz + fv * vi + offset
    return out


def main():
    if len(sys.argv) != 2:
        print(__doc__)
        return 2
    directory = sys.argv[1]
    data, tribo = load(directory)
    specs = tribo["start"]
    args = (data["t_s"], data["position_m"], data["drive_velocity_m_per_s"], data["step_velocity_m_per_s"],
            data["normal_n"], tribo["force_scale"])
    rows = data["in_fit"] > 0
    measured = data["force_n"][rows]
    theta0 = np.array([s["theta"] for s in specs])

    def residual(theta):
        return measured - simulate(theta, specs, *args)[rows]

    # The same model as tribo's: the start's residual must agree.
    r0 = residual(theta0)
    start = time.perf_counter()
    result = least_squares(residual, theta0, method="trf", jac="2-point", x_scale="jac")
    seconds = time.perf_counter() - start
    rss = float(np.sum(result.fun ** 2))
    values = {}
    for th, s in zip(result.x, specs):
        values[s["name"]] = s["scale"] * math.exp(th) if s["transform"] == "log" else s["scale"] * th
    single = tribo["tribo_single_start"]
    report = {
        "samples": int(len(data)),
        "start_rss": float(np.sum(r0 ** 2)),
        "scipy": {"seconds": seconds, "rss": rss, "function_evaluations": int(result.nfev), "status": int(result.status),
                  "values": values},
        "tribo_single_start": single,
        "tribo_full_fit": tribo["tribo_full_fit"],
        "time_ratio_scipy_over_tribo": seconds / single["seconds"],
    }
    with open(os.path.join(directory, "scipy_fit.json"), "w") as f:
        json.dump(report, f, indent=2)
    print(f"{len(data)} samples, {int(rows.sum())} in the fit")
    print(f"scipy least_squares: {seconds:.2f} s, {result.nfev} evaluations, RSS {rss:.6g}")
    print(f"tribo (same start):  {single['seconds']:.3f} s, {single['jacobians']} Jacobians, RSS {single['rss']:.6g}")
    print(f"tribo (full multi-start fit): {tribo['tribo_full_fit']['seconds']:.3f} s")
    print(f"ratio scipy / tribo (same start): {seconds / single['seconds']:.0f}")
    for name in values:
        print(f"  {name:8s} scipy {values[name]:.6g}   tribo {single['values'][name]:.6g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
