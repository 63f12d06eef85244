#!/usr/bin/env python3
"""servo_ipd: a generator family of friction records from a soft I-PD lateral position loop.

The record is what a displacement-controlled lateral transducer reports (Srivastava 2006, §3,
§5.4, Appendix C, Table 3.2): a tip of mass m on a transducer spring, driven by an actuator
with a first-order lag, in a discrete I-PD loop that feeds back the noisy position reading;
the force channel is the loop's drive force less the spring's k x from the measured position,
so it carries the friction, the tip's inertia and the loop's transients. The contact is LuGre
(Canudas de Wit et al. 1995) with at most one effect. README.md states the model, every
effect's form and strength, the protocol and the noise model.

Usage: generate.py OUT_DIR EFFECT SEED [--strength S]
"""

import argparse
import json
import math
import os

import numpy as np

FAMILY = "servo_ipd"

EFFECTS = [
    "none",
    "dwell_stiction",
    "frictional_lag",
    "velocity_strengthening",
    "load_dependence",
    "position_periodic",
    "direction_asymmetry",
    "tilt_offset",
    "drift",
    "presliding_hysteresis",
    "backlash",
    "rate_state",
    "oov_debris",
]

# Default strengths: each effect's contribution to the recorded force, RMS over the samples it
# affects, is 3-10x the 10 µN force noise at these values (README.md, "Effects").
DEFAULT_STRENGTH = {
    "none": 0.0,
    "dwell_stiction": 0.6,
    "frictional_lag": 0.03,
    "velocity_strengthening": 0.06,
    "load_dependence": 0.4e-3,
    "position_periodic": 0.008,
    "direction_asymmetry": 0.12,
    "tilt_offset": 0.6,
    "drift": 60e-6,
    "presliding_hysteresis": 0.25,
    "backlash": 0.4e-6,
    "rate_state": 0.08,
    "oov_debris": 0.15,
}

STRENGTH_UNIT = {
    "none": "none",
    "dwell_stiction": "fraction of the levels gained after an infinitely long rest (A)",
    "frictional_lag": "s (pure delay of the speed seen by the Stribeck curve)",
    "velocity_strengthening": "fraction of Fc per unit of asinh(|v|/v_a) (c)",
    "load_dependence": "N (Derjaguin adhesion load N_adh)",
    "position_periodic": "dimensionless slope amplitude (ripple amplitude / N)",
    "direction_asymmetry": "fraction of Fc (a)",
    "tilt_offset": "deg (tilt angle theta)",
    "drift": "N (settled offset of the force reading)",
    "presliding_hysteresis": "fraction of z_ss (elastic limit r = z_ba / z_ss)",
    "backlash": "m (play width w)",
    "rate_state": "dimensionless direct-effect coefficient a (b = 1.5 a)",
    "oov_debris": "fraction of the levels lost after many passes (delta)",
}

EFFECT_INDEX = {name: i for i, name in enumerate(EFFECTS)}

# Readout floors (Table 3.2, X axis) and the normal channel.
POSITION_NOISE_M = 10e-9
POSITION_QUANTUM_M = 4e-9
FORCE_NOISE_N = 10e-6
FORCE_QUANTUM_N = 3e-6
NORMAL_NOISE_N = 0.1e-6
NORMAL_QUANTUM_N = 1e-9

MAX_SUBSTEP_S = 50e-6
STRIBECK_EXPONENT = 2.0


# ----------------------------------------------------------------------------------------
# Random draws: one stream per part, so the contact, the loop, the protocol and the noise of
# a seed are the same whatever the effect (an effect file differs from the clean file of the
# same seed by the effect alone).
# ----------------------------------------------------------------------------------------

def _streams(seed):
    children = np.random.SeedSequence(int(seed)).spawn(5)
    names = ("contact", "loop", "protocol", "noise", "effect")
    return {n: np.random.default_rng(c) for n, c in zip(names, children)}


def draw_contact(rng, mass_kg):
    mu_c = rng.uniform(0.08, 0.13)
    ratio = rng.uniform(1.15, 1.6)
    sigma0 = rng.uniform(1000.0, 6000.0)
    zeta_b = rng.uniform(0.25, 1.5)
    return {
        "mu_c": mu_c,
        "mu_s": mu_c * ratio,
        "vs_m_per_s": math.exp(rng.uniform(math.log(0.5e-6), math.log(5e-6))),
        "stribeck_exponent": STRIBECK_EXPONENT,
        "sigma0_n_per_m": sigma0,
        "sigma1_n_s_per_m": 2.0 * zeta_b * math.sqrt(sigma0 * mass_kg),
        "bristle_damping_ratio": zeta_b,
        "fv_n_s_per_m": rng.uniform(0.0, 0.5),
    }


def _loop_matrix(loop, contact, case, alpha=0.0):
    """Closed-loop one-tick map of the linearised loop (no noise, zero setpoint).

    State: plant [x, v, z, Fa] and controller [I, xm_prev, vf, u_applied]. case: 'stuck'
    (bristle elastic), 'free' (no contact force) or 'sliding' (bristle relaxing at rate alpha).
    """
    from scipy.linalg import expm

    m, ks = loop["mass_kg"], loop["spring_n_per_m"]
    kp, ki, kd = loop["kp_n_per_m"], loop["ki_n_per_m_s"], loop["kd_n_s_per_m"]
    ta, td = loop["actuator_lag_s"], loop["derivative_filter_s"]
    T = 1.0 / loop["controller_rate_hz"]
    s0, s1, fv = contact["sigma0_n_per_m"], contact["sigma1_n_s_per_m"], contact["fv_n_s_per_m"]
    if case == "free":
        s0 = s1 = fv = 0.0
    a = alpha if case == "sliding" else 0.0
    Ac = np.array([
        [0.0, 1.0, 0.0, 0.0],
        [-ks / m, -(s1 + fv) / m, (-s0 + s1 * a) / m, 1.0 / m],
        [0.0, 1.0, -a, 0.0],
        [0.0, 0.0, 0.0, -1.0 / ta],
    ])
    Bc = np.array([0.0, 0.0, 0.0, 1.0 / ta])
    aug = np.zeros((5, 5))
    aug[:4, :4] = Ac * T
    aug[:4, 4] = Bc * T
    E = expm(aug)
    Phi, Gam = E[:4, :4], E[:4, 4]
    bd = 1.0 - math.exp(-T / td)
    M = np.zeros((8, 8))
    M[:4, :4] = Phi
    M[:4, 7] = Gam                     # the command computed one tick earlier
    # controller, with xm = x (index 0)
    M[4, 0] = -ki * T                  # I += ki T (r - x)
    M[4, 4] = 1.0
    M[5, 0] = 1.0                      # xm_prev = x
    # vf += bd ((x - xm_prev)/T - vf)
    M[6, 0] = bd / T
    M[6, 5] = -bd / T
    M[6, 6] = 1.0 - bd
    # u = I_new - kp x - kd vf_new
    M[7, :] = M[4, :] - kd * M[6, :]
    M[7, 0] -= kp
    return M


def _mode_damping(M, T):
    """Smallest damping ratio of the modes of the one-tick map M (-1 if one grows), skipping
    the stuck case's conserved x - z mode (eigenvalue 1) and dead-beat zeros."""
    zmin = 1.0
    for lam in np.linalg.eigvals(M):
        if abs(lam - 1.0) < 1e-9 or abs(lam) < 1e-12:
            continue
        s = np.log(complex(lam)) / T
        if abs(s.imag) > 1e-9:
            zmin = min(zmin, -s.real / abs(s))
        elif s.real >= 0.0:
            zmin = -1.0
    return zmin


def loop_damping(loop, contact):
    """Smallest damping ratio of the closed loop over the tip's contact states: stuck, and
    sliding with the bristle relaxing at 30, 300, 3000 1/s and at the largest rate the file
    can reach (75 µm/s over the smallest steady deflection, at 0.5 mN); and, reported only,
    the damping with no contact force at all (the loop alone)."""
    T = 1.0 / loop["controller_rate_hz"]
    alpha_max = 75e-6 * contact["sigma0_n_per_m"] / (contact["mu_c"] * 0.5e-3)
    cases = [("stuck", 0.0)] + [("sliding", a) for a in (30.0, 300.0, 3000.0, alpha_max)]
    z_contact = min(_mode_damping(_loop_matrix(loop, contact, c, a), T) for c, a in cases)
    z_free = _mode_damping(_loop_matrix(loop, contact, "free"), T)
    return z_contact, z_free


def loop_noise_response(loop, contact):
    """RMS of the recorded drive force (Fa - ks xm) and of the tip's true speed caused by the
    white position noise fed back through the loop: the steady-state covariance of the
    linearised, noise-driven closed loop with the contact near stick (bristle relaxing at
    1/s). Returns (force_rms_n, speed_rms_m_per_s)."""
    T = 1.0 / loop["controller_rate_hz"]
    ki, kp, kd = loop["ki_n_per_m_s"], loop["kp_n_per_m"], loop["kd_n_s_per_m"]
    bd = 1.0 - math.exp(-T / loop["derivative_filter_s"])
    M = _loop_matrix(loop, contact, "sliding", 1.0)
    G = np.zeros(8)          # how a noise sample n in xm = x + n enters the controller
    G[4] = -ki * T
    G[5] = 1.0
    G[6] = bd / T
    G[7] = G[4] - kd * G[6] - kp
    # P = sum_k M^k Q M'^k by doubling (the slow integrator mode makes direct solvers
    # ill-conditioned)
    P = np.outer(G, G) * POSITION_NOISE_M ** 2
    A = M
    for _ in range(40):
        P = P + A @ P @ A.T
        A = A @ A
    c = np.zeros(8)
    c[3] = 1.0
    c[0] = -loop["spring_n_per_m"]
    var = c @ P @ c + (loop["spring_n_per_m"] * POSITION_NOISE_M) ** 2
    return math.sqrt(var), math.sqrt(P[1, 1])


MIN_LOOP_DAMPING = 0.1
MAX_LOOP_FORCE_NOISE_N = 8e-6
MAX_DITHER_OVER_VS = 0.3
MAX_DITHER_M_PER_S = 0.5e-6      # half the slowest commanded speed


def draw_loop(rng, contact_rng):
    """Gains of Table 5.1's order, redrawn (with the contact) until the linearised loop's
    modes are damped (ζ >= 0.1) in every contact state, the force noise the loop makes of the
    position noise is at most 8 µN (of Table 3.2's 10 µN) and the tip's speed dither from it
    is at most 0.3 vs and 0.5 µm/s (so that it neither smears the Stribeck curve nor reverses
    the slowest strokes, where LuGre would lose friction to it). Returns (loop, contact)."""
    for attempt in range(1, 5000):
        mass = rng.uniform(0.8e-3, 1.2e-3)
        ks = rng.uniform(90.0, 120.0)
        ki = rng.uniform(4500.0, 7200.0)
        lag_time = rng.uniform(0.06, 0.11)       # (kp + ks) / ki: the ramp lag per speed
        kp = lag_time * ki - ks
        zeta = rng.uniform(0.1, 0.8)
        kd = 2.0 * zeta * math.sqrt(mass * (kp + ks))
        loop = {
            "structure": "I-PD (integral on the error, P and D on the measured position)",
            "mass_kg": mass,
            "spring_n_per_m": ks,
            "kp_n_per_m": kp,
            "ki_n_per_m_s": ki,
            "kd_n_s_per_m": kd,
            "ramp_lag_time_s": lag_time,
            "loop_damping_ratio_nominal": zeta,
            "actuator_lag_s": math.exp(rng.uniform(math.log(0.2e-3), math.log(2e-3))),
            "derivative_filter_s": math.exp(rng.uniform(math.log(0.05e-3), math.log(1e-3))),
            "controller_rate_hz": float(rng.choice([4000.0, 5000.0, 10000.0])),
            "command_delay_ticks": 1,
        }
        contact = draw_contact(contact_rng, mass)
        if kp < 350.0:
            continue
        z_contact, z_free = loop_damping(loop, contact)
        if z_contact < MIN_LOOP_DAMPING:
            continue
        noise_n, dither = loop_noise_response(loop, contact)
        if (noise_n <= MAX_LOOP_FORCE_NOISE_N
                and dither <= MAX_DITHER_OVER_VS * contact["vs_m_per_s"]
                and dither <= MAX_DITHER_M_PER_S):
            loop["min_mode_damping_ratio_in_contact"] = z_contact
            loop["min_mode_damping_ratio_no_contact"] = z_free
            loop["loop_force_noise_n"] = noise_n
            loop["tip_speed_dither_m_per_s"] = dither
            loop["draws_until_accepted"] = attempt
            return loop, contact
    raise RuntimeError("no stable loop drawn")


# ----------------------------------------------------------------------------------------
# Protocol: reciprocating strokes at several loads, speed steps within some strokes, holds,
# load ramps at rest and one load ramp while sliding.
# ----------------------------------------------------------------------------------------

MIN_DURATION_S, MAX_DURATION_S = 100.0, 250.0


def build_protocol(rng):
    """Draw protocols until one lasts 100-250 s."""
    for _ in range(100):
        p = _draw_protocol(rng)
        if MIN_DURATION_S <= p["duration_s"] <= MAX_DURATION_S:
            return p
    raise RuntimeError("no protocol of 100-250 s drawn")


def _draw_protocol(rng):
    n_loads = 3
    loads = np.exp(rng.uniform(math.log(0.5e-3), math.log(10e-3), n_loads))
    # at least a factor 3 between the extremes, so the load law is seen
    while loads.max() / loads.min() < 3.0:
        loads = np.exp(rng.uniform(math.log(0.5e-3), math.log(10e-3), n_loads))
    speed_levels = np.array([1e-6, 2.5e-6, 6e-6, 12e-6, 20e-6])
    tr, xr = [0.0], [0.0]          # setpoint breakpoints
    tn, nn = [0.0], [loads[0]]     # load breakpoints
    strokes = []                   # (t_start, t_end, direction)
    t, x = 0.0, 0.0
    n_step_strokes = 0
    ramp_in_slide = None

    def hold(duration):
        nonlocal t
        t += duration
        tr.append(t)
        xr.append(x)

    hold(2.0)
    for b in range(n_loads):
        if b > 0:
            # load ramp at rest: 1.5 s hold, 1 s ramp, 1.5 s hold
            hold(1.5)
            tn.append(t)
            nn.append(loads[b - 1])
            hold(1.0)
            tn.append(t)
            nn.append(loads[b])
            hold(1.5)
        length = rng.uniform(3e-6, 12e-6)
        n_strokes = 6
        speeds = rng.permutation(speed_levels)
        speeds = np.concatenate([speeds, rng.choice(speed_levels, n_strokes - len(speeds))])
        speeds = np.minimum(speeds * np.exp(rng.uniform(-0.15, 0.15, n_strokes)), 22e-6)
        for s in range(n_strokes):
            direction = 1.0 if x < 0.5 * length else -1.0
            target = length if direction > 0 else 0.0
            v0 = speeds[s]
            t_start = t
            if rng.uniform() < 0.45:
                # speed step at a point 35-65 % along the stroke
                factor = float(rng.choice([1 / 3.0, 3.0, 1 / 10.0, 10.0]))
                v1 = min(max(v0 * factor, 0.9e-6), 22e-6)
                frac = rng.uniform(0.35, 0.65)
                x_mid = x + direction * frac * length
                t += frac * length / v0
                tr.append(t)
                xr.append(x_mid)
                t += (1 - frac) * length / v1
                n_step_strokes += 1
            else:
                t += length / v0
            x = target
            tr.append(t)
            xr.append(x)
            strokes.append((t_start, t, direction))
            if b == n_loads - 1 and s == 2 and ramp_in_slide is None:
                # a load ramp of +-30 % over this stroke, while sliding
                f = 1.3 if rng.uniform() < 0.5 and loads[b] * 1.3 <= 10e-3 else 0.7
                tn.append(t_start)
                nn.append(loads[b])
                tn.append(t)
                nn.append(loads[b] * f)
                loads[b] *= f
                ramp_in_slide = (t_start, t, f)
            if rng.uniform() < 0.5:
                hold(math.exp(rng.uniform(math.log(0.5), math.log(30.0))))
    hold(2.0)
    tn.append(t)
    nn.append(loads[-1])
    speeds_used = sorted({round(v * 1e6, 3) for v in speed_levels})
    desc = {
        "description": ("reciprocating strokes at 3 loads (6 strokes each, length 3-12 µm per "
                        "load), speeds near 1, 2.5, 6, 12, 20 µm/s, speed steps within some "
                        "strokes, holds of 0.5-30 s after half of the strokes, load "
                        "ramps of 1 s at rest between loads and one load ramp of +-30 % "
                        "during a stroke"),
        "duration_s": t,
        "loads_n": [float(v) for v in nn],
        "load_times_s": [float(v) for v in tn],
        "n_strokes": len(strokes),
        "n_strokes_with_speed_step": n_step_strokes,
        "speed_levels_um_per_s": speeds_used,
        "load_ramp_while_sliding": ramp_in_slide,
    }
    return {
        "t_ref": np.array(tr), "x_ref": np.array(xr),
        "t_load": np.array(tn), "load": np.array(nn),
        "strokes": strokes, "duration_s": t, "desc": desc,
    }


# ----------------------------------------------------------------------------------------
# Effects: parameters of each (strength from the argument or DEFAULT_STRENGTH; the shape
# parameters drawn from the effect stream).
# ----------------------------------------------------------------------------------------

def effect_parameters(effect, strength, rng, duration_s):
    p = {}
    if effect == "dwell_stiction":
        p = {"gain_A": strength, "time_constant_gamma_s": 2.0, "renewal_slip_L_m": 1.0e-6,
             "rest_slip_rate_m_per_s": 0.05e-6, "rest_filter_s": 0.02}
    elif effect == "frictional_lag":
        p = {"delay_s": strength}
    elif effect == "velocity_strengthening":
        p = {"coeff_c": strength, "activation_speed_m_per_s": 1e-6}
    elif effect == "load_dependence":
        p = {"adhesion_load_n": strength}
    elif effect == "position_periodic":
        p = {"slope_amplitude": strength,
             "wavelength_m": rng.uniform(1.0e-6, 3.0e-6),
             "phase_rad": rng.uniform(0.0, 2.0 * math.pi)}
    elif effect == "direction_asymmetry":
        p = {"asymmetry_a": strength, "transition_speed_m_per_s": 0.1e-6,
             "stronger_direction": "+x"}
    elif effect == "tilt_offset":
        p = {"angle_deg": strength, "lateral_force_direction": "+x on the tip"}
    elif effect == "drift":
        p = {"settled_offset_n": strength,
             "time_constant_s": rng.uniform(0.3, 0.6) * duration_s}
    elif effect == "presliding_hysteresis":
        p = {"elastic_limit_r": strength}
    elif effect == "backlash":
        p = {"play_width_m": strength, "drag_ratio_q": 0.1, "joint_damping_n_s_per_m": 2.0}
    elif effect == "rate_state":
        p = {"a": strength, "b": 1.5 * strength, "v0_m_per_s": 5e-6, "dc_m": 0.5e-6,
             "vr_m_per_s": 0.02e-6, "state_law": "slip (Ruina 1983)"}
    elif effect == "oov_debris":
        p = {"delta": strength, "pass_scale_P0": 4.0}
    return p


# ----------------------------------------------------------------------------------------
# Simulation
# ----------------------------------------------------------------------------------------

def simulate(loop, contact, protocol, effect, eff, noise_rng, noise=True, substep_s=MAX_SUBSTEP_S,
             traces=False, record_rate_hz=1000.0):
    """Run the loop; return the record (and, with traces, the true motion at record ticks)."""
    fc_hz = loop["controller_rate_hz"]
    T = 1.0 / fc_hz
    dur = protocol["duration_s"]
    K = int(round(dur * fc_hz)) + 1
    decim = int(round(fc_hz / record_rate_hz))
    tk = np.arange(K) * T
    r_list = np.interp(tk, protocol["t_ref"], protocol["x_ref"]).tolist()
    n_arr = np.interp(tk, protocol["t_load"], protocol["load"])
    n_list = n_arr.tolist()
    if noise:
        pos_noise = (noise_rng.normal(0.0, POSITION_NOISE_M, K)).tolist()
    else:
        noise_rng.normal(0.0, POSITION_NOISE_M, K)   # keep the stream aligned
        pos_noise = [0.0] * K
    qx = POSITION_QUANTUM_M if noise else 0.0

    m = loop["mass_kg"]
    ks = loop["spring_n_per_m"]
    kp, ki, kd = loop["kp_n_per_m"], loop["ki_n_per_m_s"], loop["kd_n_s_per_m"]
    ta, td = loop["actuator_lag_s"], loop["derivative_filter_s"]
    nsub = max(1, int(math.ceil(T / substep_s - 1e-9)))
    h = T / nsub
    Ea = math.exp(-h / ta)
    ca = ta * (1.0 - Ea) / h
    bd = 1.0 - math.exp(-T / td)
    kiT = ki * T

    s0 = contact["sigma0_n_per_m"]
    s1 = contact["sigma1_n_s_per_m"]
    fv = contact["fv_n_s_per_m"]
    mu_c, mu_s = contact["mu_c"], contact["mu_s"]
    ivs = 1.0 / contact["vs_m_per_s"]

    code = EFFECT_INDEX[effect]
    E_DWELL, E_LAG, E_VS, E_LOAD, E_PER, E_ASYM, E_TILT, E_DRIFT, E_HYS, E_BL, E_RS, E_DEB = \
        (EFFECT_INDEX[n] for n in EFFECTS[1:])
    exp, sin, fabs, log, asinh, tanh = math.exp, math.sin, math.fabs, math.log, math.asinh, math.tanh

    # effect constants
    n_adh = eff.get("adhesion_load_n", 0.0)
    if code == E_DWELL:
        dw_A, dw_g, dw_L, dw_w = (eff["gain_A"], eff["time_constant_gamma_s"],
                                  eff["renewal_slip_L_m"], eff["rest_slip_rate_m_per_s"])
        dw_b = 1.0 - math.exp(-h / eff["rest_filter_s"])
    tr_rest, s_slip, w_f = 0.0, 0.0, 0.0
    if code == E_LAG:
        nd = max(1, int(round(eff["delay_s"] / h)))
        vbuf = [0.0] * nd
        ib = 0
    if code == E_VS:
        vs_c, vs_va = eff["coeff_c"], 1.0 / eff["activation_speed_m_per_s"]
    if code == E_PER:
        pa, pk, pph = eff["slope_amplitude"], 2.0 * math.pi / eff["wavelength_m"], eff["phase_rad"]
    if code == E_ASYM:
        asa, asv = eff["asymmetry_a"], 1.0 / eff["transition_speed_m_per_s"]
    if code == E_TILT:
        th = math.radians(eff["angle_deg"])
        tilt_sin, tilt_cos = math.sin(th), math.cos(th)
    if code == E_HYS:
        hr = eff["elastic_limit_r"]
        hk = 1.0 / (1.0 - hr)
    if code == E_BL:
        bl_half = 0.5 * eff["play_width_m"]
        bl_q = eff["drag_ratio_q"]
        bl_c = eff["joint_damping_n_s_per_m"]
    d_bl, sdir = 0.0, 0
    theta = 0.0
    if code == E_RS:
        rs_a, rs_b, rs_v0, rs_dc, rs_vr = (eff["a"], eff["b"], eff["v0_m_per_s"], eff["dc_m"],
                                           eff["vr_m_per_s"])
        theta = rs_dc / rs_vr
    if code == E_DEB:
        # completed strokes by time (the pass count)
        ends = np.array([s[1] for s in protocol["strokes"]])
        passes = np.searchsorted(ends, tk, side="right").astype(float)
        deb = (1.0 - eff["delta"] * (1.0 - np.exp(-passes / eff["pass_scale_P0"]))).tolist()

    # states
    x = v = z = fa = 0.0
    v_prev = 0.0
    integ = 0.0
    xm_prev = 0.0
    vf = 0.0
    u_applied = 0.0
    nrec = (K + decim - 1) // decim
    rec_x = [0.0] * nrec
    rec_r = [0.0] * nrec
    rec_f = [0.0] * nrec
    rec_n = [0.0] * nrec
    if traces:
        tr_x = [0.0] * nrec
        tr_v = [0.0] * nrec
        tr_ff = [0.0] * nrec
        tr_es = [0.0] * nrec
    zdot = 0.0
    ir = 0
    h2 = 0.5 * h
    h4 = 0.25 * h
    mh = m / h
    for k in range(K):
        # --- measurement and controller (I-PD, one tick of computation delay) ---
        xm = x + pos_noise[k]
        if qx:
            xm = round(xm / qx) * qx
        rk = r_list[k]
        integ += kiT * (rk - xm)
        vf += bd * ((xm - xm_prev) / T - vf)
        xm_prev = xm
        u_new = integ - kp * xm - kd * vf
        if k % decim == 0:
            rec_x[ir] = xm
            rec_r[ir] = rk
            rec_f[ir] = fa - ks * xm
            nk = n_list[k]
            rec_n[ir] = nk
            if traces:
                tr_x[ir] = x
                tr_v[ir] = v
                tr_ff[ir] = s0 * z + s1 * zdot + fv * v
                tr_es[ir] = (tr_rest if code == E_DWELL else theta if code == E_RS
                             else d_bl if code == E_BL else 0.0)
            ir += 1
        u = u_applied
        u_applied = u_new

        # --- friction levels for this tick ---
        nk = n_list[k]
        fext = 0.0
        if code == E_LOAD:
            nl = nk + n_adh
        elif code == E_TILT:
            nl = nk * tilt_cos
            fext = nk * tilt_sin
        else:
            nl = nk
        Fc = mu_c * nl
        Fs = mu_s * nl
        if code == E_DEB:
            Fc *= deb[k]
            Fs *= deb[k]

        # --- plant: nsub substeps (trapezoid for the mechanics, bristle exact for frozen
        #     relaxation rate and a speed linear over the substep) ---
        for j in range(nsub):
            vm = v + 0.5 * (v - v_prev)
            av = fabs(vm)
            fc_j, fs_j = Fc, Fs
            if code == E_ASYM:
                fc_j = Fc * (1.0 + asa * tanh(vm * asv))
            elif code == E_DWELL:
                fade = 1.0 - fabs(s_slip) / dw_L
                if fade > 0.0:
                    dwm = 1.0 + dw_A * tr_rest / (tr_rest + dw_g) * fade
                    fc_j = Fc * dwm
                    fs_j = Fs * dwm
            if code == E_LAG:
                avs = fabs(vbuf[ib])
            else:
                avs = av
            q = avs * ivs
            S = fc_j + (fs_j - fc_j) * exp(-q * q)
            if code == E_VS:
                S += fc_j * vs_c * asinh(av * vs_va)
            elif code == E_RS:
                Vrs = av + rs_vr
                Mrs = 1.0 + rs_a * log(Vrs / rs_v0) + rs_b * log(rs_v0 * theta / rs_dc)
                if Mrs < 0.2:
                    Mrs = 0.2
                S *= Mrs
            if code == E_PER:
                fx = fext - nk * pa * sin(pk * (x + h2 * v) + pph)
            else:
                fx = fext

            fa_avg = u + (fa - u) * ca
            fa = u + (fa - u) * Ea

            if code == E_BL and sdir != 0:
                # the holder slides in its clamp against a drag q Fc + c_j v; the contact
                # stands still
                rhs = (mh * v + fa_avg - ks * x - ks * h4 * v - sdir * bl_q * Fc - 0.5 * bl_c * v
                       + fx)
                v1 = rhs / (mh + ks * h4 + 0.5 * bl_c)
                d_bl += h2 * (v + v1)
                x += h2 * (v + v1)
                v_prev = v
                v = v1
                zdot = 0.0
                if sdir * d_bl >= bl_half:
                    d_bl = sdir * bl_half
                    sdir = 0
                elif sdir * v1 < 0.0:
                    sdir = 0
                continue

            kap = 1.0
            if code == E_HYS:
                zss = S / s0
                if vm * z <= 0.0 or fabs(z) < hr * zss:
                    alpha = 0.0
                else:
                    kap = hk
                    alpha = av * hk / zss
            else:
                alpha = av * s0 / S
            ah = alpha * h
            if ah < 1e-3:
                E = 1.0 - ah + 0.5 * ah * ah
                c1 = h * (1.0 - 0.5 * ah + ah * ah / 6.0)
                c2 = h * (0.5 - ah / 6.0 + ah * ah / 24.0)
            else:
                E = exp(-ah)
                c1 = (1.0 - E) / alpha
                c2 = (1.0 - c1 / h) / alpha
            A = z * E + kap * v * (c1 - c2)
            B = kap * c2
            if ah < 1e-2:
                C = 0.5 * (z + A)
                D = 0.5 * B
            else:
                C = (kap * h2 * v - A + z) / ah
                D = (kap * h2 - B) / ah
            lhs = mh + ks * h4 + s0 * D + s1 * B / h + 0.5 * fv
            rhs = (mh * v + fa_avg - ks * x - ks * h4 * v - s0 * C - s1 * (A - z) / h
                   - 0.5 * fv * v + fx)
            v1 = rhs / lhs
            x += h2 * (v + v1)
            z1 = A + B * v1
            zdot = (z1 - z) / h
            z = z1
            v_prev = v
            v = v1

            # --- slow states of the effects ---
            if code == E_DWELL:
                # slip of the interface (LuGre: v - dz/dt); the dither's back-and-forth slip
                # is averaged out: rest is judged on the slip rate low-passed over 20 ms and
                # renewal on the net slip
                w = v - zdot
                w_f += dw_b * (w - w_f)
                if fabs(w_f) < dw_w:
                    tr_rest += h
                s_slip += w * h
                if fabs(s_slip) >= dw_L:
                    tr_rest = 0.0       # the contact renewed: its age starts again
                    s_slip = 0.0
            elif code == E_LAG:
                vbuf[ib] = v
                ib += 1
                if ib == nd:
                    ib = 0
            elif code == E_RS:
                Vrs = fabs(v) + rs_vr
                ph = log(Vrs * theta / rs_dc) * exp(-Vrs * h / rs_dc)
                theta = rs_dc / Vrs * exp(ph)
            elif code == E_BL:
                fcont = s0 * z + s1 * zdot + fv * v
                if fabs(fcont) > bl_q * Fc:
                    sg = 1 if fcont > 0.0 else -1
                    if sg * d_bl < bl_half and sg * v >= 0.0:
                        sdir = sg
                        z = sg * bl_q * Fc / s0
                        zdot = 0.0

    t_rec = np.arange(nrec) * (decim * T)
    out = {
        "t": t_rec,
        "x": np.array(rec_x),
        "x_ref": np.array(rec_r),
        "force": np.array(rec_f),
        "normal": np.array(rec_n),
        "substeps_per_tick": nsub,
    }
    # readout noise of the recorded force and normal channels (drawn whatever `noise` says,
    # so that the streams stay aligned)
    fnoise = noise_rng.normal(0.0, readout_noise_n(loop), nrec)
    nnoise = noise_rng.normal(0.0, NORMAL_NOISE_N, nrec)
    if code == E_DRIFT:
        out["force"] = out["force"] + eff["settled_offset_n"] * (
            1.0 - np.exp(-t_rec / eff["time_constant_s"]))
    if noise:
        out["force"] = np.round((out["force"] + fnoise) / FORCE_QUANTUM_N) * FORCE_QUANTUM_N
        out["normal"] = np.round((out["normal"] + nnoise) / NORMAL_QUANTUM_N) * NORMAL_QUANTUM_N
    if traces:
        out["x_true"] = np.array(tr_x)
        out["v_true"] = np.array(tr_v)
        out["friction_true"] = np.array(tr_ff)
        out["effect_state"] = np.array(tr_es)   # dwell: rest time; rate_state: theta; backlash: d
    return out


def readout_noise_n(loop):
    """The force readout's own noise: what makes the loop's drive noise up to 10 µN."""
    return math.sqrt(FORCE_NOISE_N ** 2 - loop["loop_force_noise_n"] ** 2)


def build(effect, seed, strength=None):
    """All the draws of one file: (loop, contact, protocol, effect params, noise rng, rate)."""
    if effect not in EFFECTS:
        raise ValueError(f"unknown effect {effect!r}; known: {', '.join(EFFECTS)}")
    if strength is None:
        strength = DEFAULT_STRENGTH[effect]
    st = _streams(seed)
    loop, contact = draw_loop(st["loop"], st["contact"])
    protocol = build_protocol(st["protocol"])
    rate_choices = [r for r in (500.0, 1000.0, 2000.0) if loop["controller_rate_hz"] % r == 0]
    rate = float(st["protocol"].choice(rate_choices))
    eff_rng = np.random.default_rng([int(seed), 1000 + EFFECT_INDEX[effect]])
    eff = effect_parameters(effect, float(strength), eff_rng, protocol["duration_s"])
    return {"loop": loop, "contact": contact, "protocol": protocol, "effect_parameters": eff,
            "noise_rng": st["noise"], "rate_hz": rate, "strength": float(strength)}


def run(effect, seed, strength=None, noise=True, substep_s=MAX_SUBSTEP_S, traces=False):
    b = build(effect, seed, strength)
    rec = simulate(b["loop"], b["contact"], b["protocol"], effect, b["effect_parameters"],
                   b["noise_rng"], noise=noise, substep_s=substep_s, traces=traces,
                   record_rate_hz=b["rate_hz"])
    return b, rec


def truth(effect, seed, b, rec):
    loop = dict(b["loop"])
    loop["substeps_per_tick"] = rec["substeps_per_tick"]
    return {
        "family": FAMILY,
        "effect": effect,
        "in_vocabulary": not effect.startswith("oov_"),
        "strength": b["strength"],
        "strength_unit": STRENGTH_UNIT[effect],
        "seed": int(seed),
        "rate_hz": b["rate_hz"],
        "contact": b["contact"],
        "effect_parameters": b["effect_parameters"],
        "loop": loop,
        "noise": {
            "position_noise_m": POSITION_NOISE_M,
            "position_quantum_m": POSITION_QUANTUM_M,
            "position_noise_in_loop": True,
            "force_noise_total_n": FORCE_NOISE_N,
            "force_noise_from_loop_n": b["loop"]["loop_force_noise_n"],
            "force_readout_noise_n": readout_noise_n(b["loop"]),
            "force_quantum_n": FORCE_QUANTUM_N,
            "normal_noise_n": NORMAL_NOISE_N,
            "normal_quantum_n": NORMAL_QUANTUM_N,
            "sampling": "decimation: each record sample is the controller tick at that instant",
        },
        "protocol": b["protocol"]["desc"],
    }


def write(out_dir, effect, seed, strength=None):
    """Write OUT_DIR/servo_ipd_<effect>_seed<seed>.csv and its .json truth; return the csv path."""
    b, rec = run(effect, seed, strength)
    os.makedirs(out_dir, exist_ok=True)
    stem = os.path.join(out_dir, f"{FAMILY}_{effect}_seed{int(seed)}")
    data = np.column_stack([rec["t"], rec["x"], rec["x_ref"], rec["force"], rec["normal"]])
    np.savetxt(stem + ".csv", data, delimiter=",", fmt=["%.6f", "%.6e", "%.6e", "%.6e", "%.6e"],
               header="t_s,x_m,x_ref_m,force_N,normal_N", comments="")
    with open(stem + ".json", "w") as f:
        json.dump(truth(effect, seed, b, rec), f, indent=2)
    return stem + ".csv"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out_dir")
    ap.add_argument("effect", choices=EFFECTS)
    ap.add_argument("seed", type=int)
    ap.add_argument("--strength", type=float, default=None,
                    help="effect strength in the effect's unit (see README.md)")
    a = ap.parse_args()
    print(write(a.out_dir, a.effect, a.seed, a.strength))


if __name__ == "__main__":
    main()
