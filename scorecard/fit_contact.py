#!/usr/bin/python3
"""Fits the rate-and-state contact of the simulated instrument to the
dissertation's break-away measurements (Table 5.1, §5.3.1), rerunnably.

  /usr/bin/python3 scorecard/fit_contact.py [--evaluations N] [--start a,b,Dc,phi0,r]

Each evaluation writes a config (config/tribod.textproto with the fitted
fields replaced, scorecard/make_config.py) and runs
`build/scorecard/tribo-scorecard --group table_5_1 --json` on it. The loss is
a penalty on friction falling with velocity (b > a) plus
the sum of squared natural-log errors of the eight Fs, ts and dl values, the
eight ds values at half weight and the three velocity overshoots (about 3x,
§5.3.1) at half weight. Nelder-Mead (scipy) in log-parameters from the start
point. Fixed, not fitted: the loop gains (from Table 5.1, see
docs/simulated_instrument.md), sigma0 (Appendix C), the dwell effect (Fig. 4.22), and the
Coulomb level, which is set from the others so that steady sliding at
13.5 um/s keeps mu = 0.0996 (§4.4), and the state of a fresh contact
(D_c / V*, the state a contact at rest relaxes to):
  coulomb = 0.0996 - (a - b) ln(1 + 13.5 um/s / V*)
Fitted: a, b, D_c, V*, and the breakaway ratio r of the elasto-plastic
presliding.
Prints every evaluation and, at the end, the best parameters as field=value
arguments for make_config.py.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np
from scipy.optimize import minimize

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCORECARD = os.path.join(ROOT, "build", "scorecard", "tribo-scorecard")
BASE = os.path.join(ROOT, "config", "tribod.textproto")
MU_13_5 = 0.0996
NAMES = ["direct_coeff", "state_coeff", "memory_length_m", "reference_velocity_m_per_s", "breakaway_ratio"]

# Fixed by the derivations in docs/simulated_instrument.md.
FIXED = [
    "controller.lateral_displacement.kp=420",
    "controller.lateral_displacement.ki=7116",
    "sim.friction.rate_state.enabled=true",
    # Fig. 4.22: slow strengthening with rest (Armstrong's dwell, eq. 5), gamma
    # 200 s from the shape of the figure's series, lost over vs = 10 um/s.
    "sim.friction.dwell_stiction.enabled=true",
    "sim.friction.dwell_stiction.gain=0.15",
    "sim.friction.dwell_stiction.time_constant_s=200",
    # memory 10 um: the held tip's position wander (~6 nm/s) must not cap the
    # contact's age below Fig. 4.22's 1000 s (D_c / |v| ~ 1700 s).
    "sim.friction.dwell_stiction.memory_length_m=10e-6",
    # §4.4: five runs spread by 1.3 %, spot to spot on the sample.
    "sim.sample.heterogeneity.enabled=true",
    "sim.friction.stribeck_velocity_m_per_s=10e-6",
    "sim.lateral.sensing.excitation_voltage_v=3.5",
]


def assignments(p):
    a, b, dc, v_star, r = p
    coulomb = MU_13_5 - (a - b) * math.log1p(13.5e-6 / v_star)
    return FIXED + [
        f"sim.friction.rate_state.direct_coeff={a:.6g}",
        f"sim.friction.rate_state.state_coeff={b:.6g}",
        f"sim.friction.rate_state.memory_length_m={dc:.6g}",
        f"sim.friction.rate_state.reference_velocity_m_per_s={v_star:.6g}",
        f"sim.friction.rate_state.initial_state_s={dc / v_star:.6g}",
        f"sim.friction.breakaway_ratio={r:.6g}",
        f"sim.friction.static_coeff={coulomb:.6g}",
        f"sim.friction.coulomb_coeff={coulomb:.6g}",
    ]


def scorecard_rows(p, groups=("table_5_1",)):
    with tempfile.NamedTemporaryFile("w", suffix=".textproto", delete=False) as f:
        path = f.name
    try:
        subprocess.run([sys.executable, os.path.join(ROOT, "scorecard", "make_config.py"), BASE, path, *assignments(p)],
                       check=True)
        cmd = [SCORECARD, "--config", path, "--json"]
        for g in groups:
            cmd += ["--group", g]
        out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    finally:
        os.unlink(path)
    return json.loads(out)["rows"]


def loss(p):
    rows = scorecard_rows(p)
    # §4.4.3: steady friction flat to slightly rising with velocity: the
    # steady mu changes by (a - b) [ln(1 + 10/V*) - ln(1 + 0.2/V*)] from 0.2
    # to 10 um/s; outside 0 to +5 % of mu it costs as much as a 2.5 % miss is
    # worth in a squared log error of 0.0025 per 2.5 %.
    rise = (p[0] - p[1]) * (math.log1p(10e-6 / p[3]) - math.log1p(0.2e-6 / p[3])) / MU_13_5
    total = (max(0.0, abs(rise - 0.025) - 0.025) / 0.025) ** 2
    for r in rows:
        o = r["observation"]
        w = 1.0 if o.split()[0] in ("Fs", "ts", "dl") else (0.5 if o.startswith(("ds", "velocity overshoot")) else 0.0)
        if w and r["simulated"] and r["simulated"] > 0:
            total += w * math.log(r["simulated"] / r["dissertation"]) ** 2
        elif w:
            total += w * 4.0
    return total


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--evaluations", type=int, default=120)
    ap.add_argument("--start", default="0.0265,0.0186,0.24e-6,1.3e-6,0.916")
    args = ap.parse_args()
    x0 = np.array([float(v) for v in args.start.split(",")])
    # log-parameters; the ratio r maps through logit to stay in (0, 1)
    def unpack(u):
        p = np.exp(u[:4]).tolist()
        return p + [1 / (1 + math.exp(-u[4]))]
    u0 = np.concatenate([np.log(x0[:4]), [math.log(x0[4] / (1 - x0[4]))]])
    best = [math.inf, None]

    def f(u):
        p = unpack(u)
        value = loss(p)
        if value < best[0]:
            best[0], best[1] = value, p
        print(f"loss {value:8.4f}  " + "  ".join(f"{n}={v:.4g}" for n, v in zip(NAMES, p)), flush=True)
        return value

    minimize(f, u0, method="Nelder-Mead",
             options={"maxfev": args.evaluations, "initial_simplex": None, "xatol": 1e-3, "fatol": 1e-4})
    print("best loss", best[0])
    print(" ".join(assignments(best[1])))


if __name__ == "__main__":
    main()
