#!/usr/bin/python3
"""scipy's LSODA against tribo's plant on the dissertation's simulated experiment.

Appendix C of the dissertation (§5.4): m = 1 g pulled for 1 s at 18 um/s by the I-PD loop
Fd = I - mk x - mkd v, dI/dt = mki (r - x), against the modified LuGre friction
(hysfricfcn04.m). States x, v, z, I, r.

  1. A fine reference: scipy's Radau at rtol 1e-11.
  2. LSODA at rtol 1e-6, in one run, timed (best of five).
  3. tribo's plant (build/bench/sim_appendix_c) at several loop rates and
     step settings, timed in-process (best of five).

Each is compared with the reference on a 1 ms grid: the friction force (max
error relative to Fs), the bristle state z (relative to zs) and the position.
The speed ratio is LSODA's time over tribo's at the setting whose errors are
at or below LSODA's (matched accuracy).

Usage: /usr/bin/python3 bench/lsoda_compare.py [build/bench/sim_appendix_c]
Needs Debian's python3-numpy and python3-scipy.
"""

import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from scipy.integrate import solve_ivp

M = 1e-3
ZS = 0.41e-6
Z0 = ZS / 3.1
FS = 1400e-6
S0 = FS / ZS
S1 = 3 * np.sqrt(M * S0)
S2 = 0.001
VS = 1.2e-6
MK, MKI, MKD = 1394.0, 7167.0, 50.0
V_PULL = 18e-6
GRID = np.linspace(0.0, 1.0, 1001)
# State scales for the absolute tolerances: x, v, z, I, r.
SCALE = np.array([1e-5, 2e-5, 1e-7, 1e-3, 1e-5])


def friction(v, z):
    g = Z0 + (ZS - Z0) * np.exp(-np.abs(v) / VS)
    dz = v - np.abs(v) * z / g
    return S0 * z + S1 * dz + S2 * v, dz


def rhs(_t, s):
    x, v, z, i, r = s
    f, dz = friction(v, z)
    fd = i - MK * x - MKD * v
    return [v, (fd - f) / M, dz, MKI * (r - x), V_PULL]


def solve(method, rtol):
    sol = solve_ivp(rhs, (0.0, 1.0), [0.0] * 5, method=method, rtol=rtol, atol=rtol * SCALE, t_eval=GRID)
    if not sol.success:
        raise RuntimeError(f"{method} failed: {sol.message}")
    x, v, z = sol.y[0], sol.y[1], sol.y[2]
    return {"x": x, "z": z, "f": friction(v, z)[0], "steps": sol.t.size, "nfev": sol.nfev}


def timed(fn, repeats=5):
    best, result = float("inf"), None
    for _ in range(repeats):
        start = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - start)
    return best, result


def errors(run, ref):
    return {
        "friction": np.max(np.abs(run["f"] - ref["f"])) / FS,
        "z": np.max(np.abs(run["z"] - ref["z"])) / ZS,
        "x_nm": np.max(np.abs(run["x"] - ref["x"])) * 1e9,
    }


def tribo(binary, rate_hz, h_lambda):
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "run.csv")
        seconds = float(subprocess.run([binary, str(rate_hz), str(h_lambda), out, "5"], check=True,
                                       capture_output=True, text=True).stdout)
        data = np.loadtxt(out, delimiter=",", skiprows=1)
    if data.shape[0] != GRID.size or np.max(np.abs(data[:, 0] - GRID)) > 1e-9:
        raise RuntimeError("tribo's output is not on the 1 ms grid")
    return seconds, {"x": data[:, 1], "z": data[:, 3], "f": data[:, 4]}


def main():
    binary = sys.argv[1] if len(sys.argv) > 1 else os.path.join("build", "bench", "sim_appendix_c")
    ref = solve("Radau", 1e-11)
    print(f"reference: Radau rtol 1e-11; final friction {ref['f'][-1] * 1e6:.3f} uN, "
          f"peak {np.max(ref['f']) * 1e6:.3f} uN, lag {(V_PULL - ref['x'][-1]) * 1e6:.4f} um")

    lsoda_s, lsoda = timed(lambda: solve("LSODA", 1e-6))
    e = errors(lsoda, ref)
    print(f"LSODA rtol 1e-6: {lsoda_s * 1e3:8.2f} ms ({lsoda['nfev']} evaluations); errors: friction "
          f"{e['friction']:.2e} Fs, z {e['z']:.2e} zs, x {e['x_nm']:.3f} nm")

    matched = None
    for rate, h_lambda in [(1e4, 1.0), (2e4, 1.0), (5e4, 1.0), (5e4, 0.25)]:
        seconds, run = tribo(binary, rate, h_lambda)
        t = errors(run, ref)
        within = t["friction"] <= e["friction"] and t["z"] <= e["z"]
        print(f"tribo {rate / 1e3:4.0f} kHz, h*lambda {h_lambda:4.2f}: {seconds * 1e3:8.2f} ms; errors: friction "
              f"{t['friction']:.2e} Fs, z {t['z']:.2e} zs, x {t['x_nm']:.3f} nm; LSODA / tribo time "
              f"{lsoda_s / seconds:6.1f}{'  (matched accuracy)' if within and matched is None else ''}")
        if within and matched is None:
            matched = lsoda_s / seconds
    if matched is None:
        print("no tribo setting reached LSODA's accuracy")
    else:
        print(f"speed ratio at matched accuracy: tribo {matched:.2f}x LSODA's speed")

    # The instrument's controller is digital: the drive is held over each
    # tick. Solving that with LSODA means one integration per tick.
    span = 0.05
    start = time.perf_counter()
    sampled_lsoda(span, 1e4)
    per_second = (time.perf_counter() - start) / span
    seconds, _ = tribo(binary, 1e4, 1.0)
    print(f"with a 10 kHz sampled controller, LSODA restarted every tick: {per_second:.2f} s per simulated "
          f"second ({span} s measured); tribo {seconds * 1e3:.2f} ms: {per_second / seconds:.0f}x faster")
    return 0


def sampled_lsoda(span, rate_hz):
    """Appendix C with the integral term held over each tick (the drive of a digital loop)."""
    dt = 1.0 / rate_hz
    state = np.zeros(4)  # x, v, z and the held integral
    integral = 0.0
    for k in range(int(round(span / dt))):
        t0 = k * dt
        error = V_PULL * t0 - state[0]
        held = integral + MKI * error * dt / 2

        def plant(_t, s):
            x, v, z = s
            f, dz = friction(v, z)
            return [v, (held - MK * x - MKD * v - f) / M, dz]

        sol = solve_ivp(plant, (t0, t0 + dt), state[:3], method="LSODA", rtol=1e-6, atol=1e-6 * SCALE[:3])
        state[:3] = sol.y[:, -1]
        integral += MKI * dt * (error + V_PULL * (t0 + dt) - state[0]) / 2


if __name__ == "__main__":
    sys.exit(main())
