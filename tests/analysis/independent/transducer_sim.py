#!/usr/bin/python3
"""An independent test-data generator for tribo-fit (not tribo's sim code).

A displacement-controlled lateral transducer at the floors of the
dissertation's Table 3.2 (X axis): 10 nm RMS position noise, 4 nm position
resolution, 3 uN force resolution, sampled at 500 Hz. The tip follows a
commanded reference through the closed loop: a critically damped
second-order response at 25 Hz in series with a 60 Hz first-order lag (the
actuator), and a servo compliance: the tip lags the loop's command by
sigma0 z / 20 000 N/m (8 nm at 160 uN), so the motion feels the friction. The contact is LuGre
(Canudas de Wit et al. 1995) with the exponential Stribeck curve and
randomised parameters; at most one hidden effect per file, each in its own
form (written here, not taken from the analysis):

  dwell_stiction          levels x (1 + beta ln(1 + t_dwell / 0.1 s) exp(-s / D)), s = slip since onset
  frictional_lag          the Stribeck curve sees a first-order lag of the speed (tau)
  velocity_strengthening  levels x (1 + c ln(|v| / 1 um/s)) (floored at 0.05 um/s)
  load_dependence         levels x (N / 1 mN)^(-1/3)  (F ~ N^(2/3))
  position_periodic       levels x (1 + a sin(2 pi x / L))
  direction_asymmetry     levels x (1 + a sgn v)
  tilt_offset             + N tan(theta), also at rest
  drift                   + a ramp in time plus a slow wobble (reading drift)
  presliding_hysteresis   elasto-plastic presliding (Dupont et al. 2002), z_ba = r z_ss
  backlash                play in series: the contact unloads to zero on reversal, the
                          gap b is crossed with no force, then the bristle reloads
  wear_in (outside the vocabulary) levels x (1 + w (1 - exp(-S / 20 um))), S = total slip
  rate_state              levels x (1 + a ln(|v| / V*) + b ln(V* theta / Dc)) (|v| floored at
                          0.05 um/s), theta by Dieterich's ageing law d theta/dt = 1 - |v| theta / Dc
                          (exact at each substep's speed), V* = 1 um/s, Dc = 1 um, b = 1.2 a,
                          theta at the start Dc / V*; its passes step in speed half-way (below)

Protocol: loads 0.5, 1, 2 mN reached at rest; 5 um passes both ways at 0.5,
2, 8 and 20 um/s, each after a hold of 0.25-8 s; about 150 s. With speed steps
(rate_state's files, or --steps): each pass slides its first 2.5 um at its speed
and the rest at three times it (the passes towards +x) or the other way round
(towards -x), so the friction's response to a speed change within sliding is
in the record; about 120 s.

Writes CSV columns t_s, x_m, x_ref_m, force_N, normal_N (the contract of
`tribo-fit diagnose FILE --time t_s --position x_m --force force_N --normal
normal_N --reference x_ref_m`) and a JSON file with the truth.

Outside those thirteen, with holds of minutes (--holds: at 1 and 2 mN, four
5 um passes at 2 um/s both ways, each followed by a 25 nm step back and a
100 s hold; about 840 s), which creep's files use:

  creep                   the sample moves at a constant speed s along +x under the
                          tip: the contact sees the tip's velocity less s (a stuck
                          contact loads at sigma0 s)

usage: transducer_sim.py OUT_DIR EFFECT SEED [--strength S] [--steps] [--holds]
"""
import json
import math
import os
import sys

import numpy as np

RATE_HZ = 500.0
SUBSTEPS = 8
POSITION_NOISE_M = 10e-9
POSITION_RESOLUTION_M = 4e-9
FORCE_RESOLUTION_N = 3e-6
FORCE_NOISE_N = 1e-6

# Default strengths (relative unless stated): the "config strength" of each effect.
DEFAULT_STRENGTH = {
    "none": 0.0,
    "dwell_stiction": 0.08,          # beta
    "frictional_lag": 0.03,          # tau, s
    "velocity_strengthening": 0.03,  # c per e-fold
    "load_dependence": 1.0,          # on/off (exponent 2/3)
    "position_periodic": 0.08,       # relative amplitude
    "direction_asymmetry": 0.10,     # relative level difference
    "tilt_offset": 0.02,             # tan(theta)
    "drift": 0.3e-6,                 # N/s ramp (plus a wobble of 20x that in N)
    "presliding_hysteresis": 0.5,    # breakaway ratio r
    "backlash": 0.3e-6,              # gap, m
    "wear_in": 0.15,                 # relative rise over 20 um of slip
    "rate_state": 0.05,              # a, relative (b = RS_B_OVER_A a)
}
STEPPED_EFFECTS = {"rate_state"}  # their files use the protocol with speed steps
# Outside the 13-effect contract above: effects whose files use the protocol
# with holds of minutes (--holds), and their default strengths.
HOLD_EFFECTS = {"creep": 0.3e-9}  # the sample's creep speed along +x, m/s
RS_B_OVER_A = 1.2  # rate_state: the evolution's coefficient b over the direct effect's a
EFFECTS = list(DEFAULT_STRENGTH)


def protocol(rng, steps=False):
    """Reference position and normal load knots: list of (t, x, N)."""
    knots = [(0.0, 0.0, 0.0)]
    t, x = 0.0, 0.0
    holds = [0.25, 0.5, 1.0, 2.0, 4.0, 8.0]
    k = 0
    for load in (0.5e-3, 1e-3, 2e-3):
        t += 1.0
        knots.append((t, x, load))  # loading ramp at rest
        t += 0.5
        knots.append((t, x, load))
        for speed in (0.5e-6, 2e-6, 8e-6, 20e-6):
            for direction in (1, -1):
                t += holds[k % len(holds)]
                k += 1
                knots.append((t, x, load))
                if steps:  # half at one speed, half at three times it
                    first, second = (speed, 3 * speed) if direction > 0 else (3 * speed, speed)
                    for v in (first, second):
                        x += direction * 2.5e-6
                        t += 2.5e-6 / v
                        knots.append((t, x, load))
                    continue
                x += direction * 5e-6
                t += 5e-6 / speed
                knots.append((t, x, load))
        t += 0.5
        knots.append((t, x, load))
    return knots


def holds_protocol():
    """Holds of minutes: at 1 and 2 mN, four 5 um passes at 2 um/s both ways,
    each followed by a 25 nm step back at 0.5 um/s and a 100 s hold; about 840 s."""
    knots = [(0.0, 0.0, 0.0)]
    t, x = 0.0, 0.0
    for load in (1e-3, 2e-3):
        t += 1.0
        knots.append((t, x, load))
        t += 2.0
        knots.append((t, x, load))
        for direction in (1, -1, 1, -1):
            x += direction * 5e-6
            t += 5e-6 / 2e-6
            knots.append((t, x, load))
            x -= direction * 25e-9
            t += 25e-9 / 0.5e-6
            knots.append((t, x, load))
            t += 100.0
            knots.append((t, x, load))
    return knots


def interpolate(knots, t):
    kt = np.array([k[0] for k in knots])
    return np.interp(t, kt, [k[1] for k in knots]), np.interp(t, kt, [k[2] for k in knots])


def random_contact(rng):
    mu_c = rng.uniform(0.08, 0.12)
    return {
        "mu_c": mu_c,
        "mu_s": mu_c * rng.uniform(1.2, 1.6),
        "vs_m_per_s": rng.uniform(0.5e-6, 3e-6),
        "sigma0_n_per_m": rng.uniform(1500.0, 4000.0),
        "sigma1_n_s_per_m": rng.uniform(1.0, 6.0),
        "fv_n_s_per_m": rng.uniform(0.05, 0.5),
    }


def simulate(effect, seed, strength=None, steps=None, holds=None):
    rng = np.random.default_rng(seed)
    p = random_contact(rng)
    s = {**DEFAULT_STRENGTH, **HOLD_EFFECTS}[effect] if strength is None else strength
    steps = effect in STEPPED_EFFECTS if steps is None else steps
    holds = effect in HOLD_EFFECTS if holds is None else holds
    knots = holds_protocol() if holds else protocol(rng, steps)
    duration = knots[-1][0]
    dt = 1.0 / (RATE_HZ * SUBSTEPS)
    n = int(duration * RATE_HZ * SUBSTEPS)
    t = np.arange(n) * dt
    ref, normal = interpolate(knots, t)
    # Closed-loop tracking: critically damped 2nd order, 25 Hz (semi-implicit steps).
    wn = 2 * math.pi * 25.0
    pole = 2 * math.pi * 60.0
    xc = np.empty(n)
    xi, vi, yi = 0.0, 0.0, 0.0
    for i in range(n):
        a = wn * wn * (ref[i] - xi) - 2 * wn * vi
        vi += a * dt
        xi += vi * dt
        yi += (xi - yi) * (1 - math.exp(-pole * dt))
        xc[i] = yi
    phase = rng.uniform(0, 2 * math.pi)
    period_m = rng.uniform(0.8e-6, 1.6e-6)
    # Friction, sequential.
    force = np.empty(n)
    z = 0.0
    v_lag = 0.0
    slip_since_onset = 0.0
    total_slip = 0.0
    rest_time = 0.0
    dwell_at_onset = 0.0
    rs_v_ref, rs_dc = 1e-6, 1e-6
    theta = rs_dc / rs_v_ref
    moving = False
    x_contact = 0.0  # backlash: position of the contact behind the play
    sig0, sig1, fv = p["sigma0_n_per_m"], p["sigma1_n_s_per_m"], p["fv_n_s_per_m"]
    rest_speed = 0.02e-6
    k_servo = 20000.0
    x = np.empty(n)
    v = np.empty(n)
    f_prev = 0.0
    x_prev = 0.0
    for i in range(n):
        x[i] = xc[i] - f_prev / k_servo
        vi = (x[i] - x_prev) / dt if i > 0 else 0.0
        x_prev = x[i]
        v[i] = vi
        N = normal[i]
        # Contact motion (backlash: the contact moves only when the tip pushes it).
        if effect == "backlash":
            half = 0.5 * s
            d = x[i] - x_contact
            engaged = abs(d) >= half
            if d > half:
                x_contact = x[i] - half
            elif d < -half:
                x_contact = x[i] + half
            vc = vi if engaged else 0.0
        elif effect == "creep":  # the sample moves at s under the tip: the contact sees v - s
            engaged, vc = True, vi - s
        else:
            engaged, vc = True, vi
        speed = abs(vc)
        if speed < rest_speed:
            rest_time += dt
            if moving:
                moving = False
        else:
            if not moving:
                moving = True
                dwell_at_onset = rest_time
                slip_since_onset = 0.0
            rest_time = 0.0
            slip_since_onset += speed * dt
            total_slip += speed * dt
        level = 1.0
        if effect == "load_dependence" and N > 1e-5:
            level *= (N / 1e-3) ** (-1.0 / 3.0)
        if effect == "position_periodic":
            level *= 1 + s * math.sin(2 * math.pi * x[i] / period_m + phase)
        if effect == "direction_asymmetry" and vc != 0:
            level *= 1 + s * math.copysign(1.0, vc)
        if effect == "velocity_strengthening":
            level *= 1 + s * math.log(max(speed, 0.05e-6) / 1e-6)
        if effect == "dwell_stiction":
            level *= 1 + s * math.log(1 + dwell_at_onset / 0.1) * math.exp(-slip_since_onset / 0.5e-6)
        if effect == "wear_in":
            level *= 1 + s * (1 - math.exp(-total_slip / 20e-6))
        if effect == "rate_state":
            if speed < rest_speed:
                theta += dt
            else:
                theta = rs_dc / speed + (theta - rs_dc / speed) * math.exp(-speed * dt / rs_dc)
            level *= 1 + s * math.log(max(speed, 0.05e-6) / rs_v_ref) + RS_B_OVER_A * s * math.log(rs_v_ref * theta / rs_dc)
        v_str = speed
        if effect == "frictional_lag":
            v_lag += (speed - v_lag) * (1 - math.exp(-dt / s))
            v_str = v_lag
        Fc, Fs = p["mu_c"] * N * level, p["mu_s"] * N * level
        g = max((Fc + (Fs - Fc) * math.exp(-v_str / p["vs_m_per_s"])) / sig0, 1e-15)
        if effect == "backlash" and not engaged:
            z = 0.0
            dz = 0.0
        elif effect == "presliding_hysteresis":
            zba = s * g
            alpha = 0.0
            if vc * z > 0 and abs(z) > zba:
                if abs(z) >= g:
                    alpha = 1.0
                else:
                    alpha = 0.5 * math.sin(math.pi * (abs(z) - 0.5 * (g + zba)) / (g - zba)) + 0.5
            dz = vc - alpha * speed * z / g
            z += dz * dt
        else:
            # exact relaxation over the substep at constant velocity
            if speed > 0:
                target = math.copysign(g, vc)
                z_new = target + (z - target) * math.exp(-speed * dt / g)
            else:
                z_new = z
            dz = (z_new - z) / dt
            z = z_new
        f = sig0 * z + sig1 * dz + fv * vc
        if effect == "tilt_offset":
            f += N * s
        if effect == "drift":
            f += s * t[i] + 20 * s * math.sin(2 * math.pi * t[i] / 60.0)
        force[i] = f
        f_prev = sig0 * z  # the bristle's elastic force loads the servo (its damping term would make the explicit step unstable)
    keep = slice(0, n, SUBSTEPS)
    t_out = t[keep]
    x_true = x[keep]
    x_meas = x_true + rng.normal(0, POSITION_NOISE_M, x_true.size)
    x_meas = np.round(x_meas / POSITION_RESOLUTION_M) * POSITION_RESOLUTION_M
    f_meas = force[keep] + rng.normal(0, FORCE_NOISE_N, x_true.size)
    f_meas = np.round(f_meas / FORCE_RESOLUTION_N) * FORCE_RESOLUTION_N
    n_meas = normal[keep] + rng.normal(0, 0.1e-6, x_true.size)
    truth = {"effect": effect, "strength": s, "seed": seed, "contact": p,
             "rate_hz": RATE_HZ, "position_noise_m": POSITION_NOISE_M,
             "position_resolution_m": POSITION_RESOLUTION_M,
             "force_resolution_n": FORCE_RESOLUTION_N, "force_noise_n": FORCE_NOISE_N}
    if effect == "position_periodic":
        truth["period_m"] = period_m
    if effect == "rate_state":
        b = RS_B_OVER_A * s
        truth["rate_state"] = {"a_rel": s, "b_rel": b, "a_mu": s * p["mu_c"], "b_mu": b * p["mu_c"],
                               "dc_m": rs_dc, "v_ref_m_per_s": rs_v_ref, "law": "ageing"}
    truth["speed_steps"] = steps
    truth["holds_of_minutes"] = holds
    columns = {"t_s": t_out, "x_m": x_meas, "x_ref_m": ref[keep], "force_N": f_meas, "normal_N": n_meas,
               "v_true_m_s": v[keep], "x_true_m": x_true}
    return columns, truth


def write(out_dir, effect, seed, strength=None, steps=None, holds=None):
    os.makedirs(out_dir, exist_ok=True)
    columns, truth = simulate(effect, seed, strength, steps, holds)
    stepped = truth["speed_steps"] and effect not in STEPPED_EFFECTS
    held = truth["holds_of_minutes"] and effect not in HOLD_EFFECTS
    stem = os.path.join(out_dir, f"{effect}{'_steps' if stepped else ''}{'_holds' if held else ''}_seed{seed}")
    names = list(columns)
    data = np.column_stack([columns[k] for k in names])
    np.savetxt(stem + ".csv", data, delimiter=",", header=",".join(names), comments="", fmt="%.9g")
    with open(stem + ".json", "w") as f:
        json.dump(truth, f, indent=1)
    return stem + ".csv"


if __name__ == "__main__":
    args = sys.argv[1:]
    strength = None
    if "--strength" in args:
        k = args.index("--strength")
        strength = float(args[k + 1])
        del args[k:k + 2]
    steps = None
    if "--steps" in args:
        args.remove("--steps")
        steps = True
    holds = None
    if "--holds" in args:
        args.remove("--holds")
        holds = True
    if len(args) != 3 or args[1] not in EFFECTS + list(HOLD_EFFECTS):
        sys.exit(__doc__)
    print(write(args[0], args[1], int(args[2]), strength, steps, holds))
