#!/usr/bin/python3
"""Test records of a lateral friction transducer under a soft PID position loop.

Family `electrostatic_pid`: the tip sits on the spring-suspended centre plate of a
three-plate capacitive transducer, pushed by an electrostatic drive whose force command
comes from a PID position loop that is soft against the contact. The recorded force is
the drive force the instrument reports (plate force less the calibrated spring force),
not the contact force. The model, every effect's form and its default strength are in
README.md beside this file.

Usage:
    generate.py OUT_DIR EFFECT SEED [--strength S]
writes OUT_DIR/electrostatic_pid_<EFFECT>_seed<SEED>.csv (t_s,x_m,x_ref_m,force_N,normal_N)
and the truth OUT_DIR/electrostatic_pid_<EFFECT>_seed<SEED>.json.
"""

import argparse
import json
import math
import os
import zlib

import numpy as np
from scipy.linalg import expm
from scipy.signal import lfilter

FAMILY = "electrostatic_pid"

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
    "oov_humidity_cycle",
]

IN_VOCABULARY = {e: not e.startswith("oov_") for e in EFFECTS}

# Default strengths: chosen so that each effect changes the recorded force by several
# times the 10 µN force noise where it acts (README.md, "Effects").
DEFAULT_STRENGTH = {
    "none": 0.0,
    "dwell_stiction": 0.8,
    "frictional_lag": 0.05,
    "velocity_strengthening": 0.12,
    "load_dependence": 50.0,
    "position_periodic": 0.015,
    "direction_asymmetry": 0.15,
    "tilt_offset": 1.0,
    "drift": 80.0,
    "presliding_hysteresis": 0.4,
    "backlash": 0.25,
    "rate_state": 0.12,
    "oov_humidity_cycle": 0.2,
}

STRENGTH_UNIT = {
    "none": "none",
    "dwell_stiction": "beta: Fs_eff = max(Fc, Fs (1 + beta ((age / 1 s)^0.3 - 1)))",
    "frictional_lag": "s (pure delay of the speed seen by the Stribeck level)",
    "velocity_strengthening": "c: added level c*Fc*asinh(|v|/v_a), dimensionless",
    "load_dependence": "µN (adhesive friction term tau*A at 1 mN; A follows Hertz, N^(2/3))",
    "position_periodic": "first-harmonic ripple amplitude / normal load (dimensionless)",
    "direction_asymmetry": "a: Coulomb level Fc*(1 + a) in the favoured direction, Fc*(1 - a) in the other",
    "tilt_offset": "degrees (tilt of the contact plane)",
    "drift": "µN (amplitude of the thermal settling of the force reading; random walk scaled with it)",
    "presliding_hysteresis": "w: share of the Coulomb level carried by the Maxwell-slip elements",
    "backlash": "µm (total width 2b of the compliant gap)",
    "rate_state": "a: direct-effect coefficient on the Coulomb level (b = ratio*a)",
    "oov_humidity_cycle": "relative amplitude of the slow humidity modulation of both friction levels",
}

# Readout floors (dissertation Table 3.2, X axis; normal load noise floor of the Z axis).
POSITION_NOISE_M = 10e-9
POSITION_STEP_M = 4e-9
FORCE_NOISE_N = 10e-6
FORCE_STEP_N = 3e-6
NORMAL_NOISE_N = 0.1e-6
NORMAL_STEP_N = 1e-9

RECORD_RATES_HZ = [1000, 2500, 5000, 10000]
MAX_DURATION_S = {1000: 230.0, 2500: 170.0, 5000: 110.0, 10000: 55.0}
CONTROLLER_RATES_HZ = [5000, 10000, 20000]
MAX_SUBSTEP_S = 2.5e-5          # plant sub-step bound (README.md, "Numerics")
DRIVE_LIMIT_N = 5e-3            # actuator clamp, anti-windup limit
WINDOW_M = 7.0e-6               # strokes stay within +-7 µm of the plate's rest point
MIN_LOOP_DAMPING = 0.05         # every closed-loop pole of the linearised loop
MIN_GAIN_MARGIN = 2.5
MIN_PHASE_MARGIN_DEG = 35.0
KD_DAMPING_RANGE = (0.6, 1.2)   # kd = 2 zeta sqrt(m (kp + k)) - c, zeta drawn here
DERIVATIVE_FILTER_HZ = (300.0, 1000.0)
DEMODULATOR_HZ = (300.0, 600.0)


def _stable_salt(text):
    return zlib.crc32(text.encode("utf-8"))


def _log_uniform(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


# ----------------------------------------------------------------------------------------
# Parameters


def draw_contact(rng):
    mu_c = rng.uniform(0.07, 0.14)
    ratio = rng.uniform(1.1, 1.7)
    return {
        "mu_c": float(mu_c),
        "mu_s": float(mu_c * ratio),
        "vs_m_per_s": _log_uniform(rng, 0.3e-6, 6e-6),
        "stribeck_exponent": 1.0,
        "sigma0_n_per_m": _log_uniform(rng, 800.0, 8000.0),
        "sigma1_n_s_per_m": _log_uniform(rng, 0.3, 10.0),
        "fv_n_s_per_m": float(rng.uniform(0.0, 1.0)),
    }


def _loop_matrix(plant, loop, contact_stiffness, contact_damping):
    """Discrete closed-loop state matrix of the linearised loop (reference 0).

    State: x, v, plate force p, dp/dt, delayed command, integrator, derivative term,
    previous measurement.
    """
    m, k, c = plant["mass_kg"], plant["spring_n_per_m"], plant["damping_n_s_per_m"]
    wd = 2 * math.pi * loop["drive_bandwidth_hz"]
    zd = loop["drive_damping_ratio"]
    tc = 1.0 / loop["controller_rate_hz"]
    a = np.array([
        [0, 1, 0, 0],
        [-(k + contact_stiffness) / m, -(c + contact_damping) / m, 1 / m, 0],
        [0, 0, 0, 1],
        [0, 0, -wd * wd, -2 * zd * wd],
    ])
    b = np.array([0, 0, 0, wd * wd])
    big = np.zeros((5, 5))
    big[:4, :4] = a * tc
    big[:4, 4] = b * tc
    e = expm(big)
    ad, bd = e[:4, :4], e[:4, 4]
    kp, ki, kd = loop["kp_n_per_m"], loop["ki_n_per_m_s"], loop["kd_n_s_per_m"]
    tf = 1.0 / (2 * math.pi * loop["derivative_filter_hz"])
    # y = x (measurement at the tick). Command u = -kp y + I + D.
    # D' = (tf D - kd (y - y_prev)) / (tf + tc); I' = I - ki tc y; command applied a tick later.
    n = 8
    mat = np.zeros((n, n))
    mat[:4, :4] = ad
    mat[:4, 4] = bd
    dy = np.zeros(n)
    dy[0] = 1.0
    y = dy
    d_new = (tf * np.eye(n)[6] - kd * (y - np.eye(n)[7])) / (tf + tc)
    i_new = np.eye(n)[5] - ki * tc * y
    u = -kp * y + np.eye(n)[5] + d_new
    mat[4] = u
    mat[5] = i_new
    mat[6] = d_new
    mat[7] = y
    return mat


def _contact_cases(contact):
    """Linearised contact: stuck (bristle stiffness and damping), half-stuck, sliding."""
    s0, s1, fv = contact["sigma0_n_per_m"], contact["sigma1_n_s_per_m"], contact["fv_n_s_per_m"]
    return [(s0, s1 + fv), (0.25 * s0, s1 + fv), (0.0, fv)]


def loop_damping(plant, loop, contact):
    """Smallest damping ratio of the closed-loop poles over the contact cases."""
    worst = 1.0
    tc = 1.0 / loop["controller_rate_hz"]
    for ks, cs in _contact_cases(contact):
        eig = np.linalg.eigvals(_loop_matrix(plant, loop, ks, cs))
        for lam in eig:
            if abs(lam) < 1e-12:
                continue
            s = np.log(lam) / tc
            if abs(s) < 1e-9:
                continue
            worst = min(worst, float(-s.real / abs(s)))
    return worst


def loop_margins(plant, loop, contact_stiffness, contact_damping, points=3000):
    """Gain margin (factor) and phase margin (degrees) of the discrete loop
    L(z) = C(z) z^-1 P(z): P the zero-order-hold plant with its drive stage, C the PID
    as implemented (integrator on past errors, filtered derivative on the measurement)."""
    m, k, c = plant["mass_kg"], plant["spring_n_per_m"], plant["damping_n_s_per_m"]
    wd = 2 * math.pi * loop["drive_bandwidth_hz"]
    zd = loop["drive_damping_ratio"]
    tc = 1.0 / loop["controller_rate_hz"]
    a = np.array([
        [0, 1, 0, 0],
        [-(k + contact_stiffness) / m, -(c + contact_damping) / m, 1 / m, 0],
        [0, 0, 0, 1],
        [0, 0, -wd * wd, -2 * zd * wd],
    ])
    big = np.zeros((5, 5))
    big[:4, :4] = a * tc
    big[:4, 4] = np.array([0, 0, 0, wd * wd]) * tc
    e = expm(big)
    ad, bd = e[:4, :4], e[:4, 4]
    kp, ki, kd = loop["kp_n_per_m"], loop["ki_n_per_m_s"], loop["kd_n_s_per_m"]
    tf = 1.0 / (2 * math.pi * loop["derivative_filter_hz"])
    w = np.geomspace(1.0, math.pi / tc * 0.999, points)
    z = np.exp(1j * w * tc)
    lam, vec = np.linalg.eig(ad)
    resid = vec[0, :] * np.linalg.solve(vec, bd)          # P(z) = sum_i resid_i / (z - lam_i)
    pz = (resid[None, :] / (z[:, None] - lam[None, :])).sum(axis=1)
    cz = kp + ki * tc / (z - 1) + kd * (1 - 1 / z) / (tf + tc - tf / z)
    lz = cz * pz / z
    mag = np.abs(lz)
    ph = np.unwrap(np.angle(lz))
    gm, pm = math.inf, math.inf
    for i in range(points - 1):
        if (mag[i] - 1) * (mag[i + 1] - 1) <= 0:
            pm = min(pm, float(np.degrees(np.mod(ph[i] + 2 * math.pi, 2 * math.pi) - math.pi)))
        r0, r1 = np.mod(ph[i] + math.pi, 2 * math.pi), np.mod(ph[i + 1] + math.pi, 2 * math.pi)
        if abs(r0 - r1) > math.pi:       # phase crosses -180 degrees
            gm = min(gm, float(1.0 / max(mag[i], 1e-300)))
    return gm, pm


def loop_robustness(plant, loop, contact):
    """Worst gain and phase margins over the contact cases."""
    gm, pm = math.inf, math.inf
    for ks, cs in _contact_cases(contact):
        g, p = loop_margins(plant, loop, ks, cs)
        gm, pm = min(gm, g), min(pm, p)
    return gm, pm


def loop_acceptable(plant, loop, contact):
    """(accepted, pole damping, gain margin, phase margin) of a drawn loop."""
    damping = loop_damping(plant, loop, contact)
    if damping < MIN_LOOP_DAMPING:
        return False, damping, 0.0, 0.0
    gm, pm = loop_robustness(plant, loop, contact)
    return gm >= MIN_GAIN_MARGIN and pm >= MIN_PHASE_MARGIN_DEG, damping, gm, pm


def draw_controller_rate(rng, rate_hz):
    allowed = [f for f in CONTROLLER_RATES_HZ if f % rate_hz == 0 and f >= rate_hz]
    return int(allowed[rng.integers(len(allowed))])


def draw_plant_and_loop(rng, contact, fc):
    """Plate mass, drive stage and gains drawn together, redrawn until the linearised
    loop has pole damping >= MIN_LOOP_DAMPING and gain and phase margins of at least
    MIN_GAIN_MARGIN and MIN_PHASE_MARGIN_DEG for stuck, half-stuck and sliding contact."""
    plant = {
        "spring_n_per_m": float(rng.uniform(90.0, 120.0)),
        "damping_n_s_per_m": float(rng.uniform(0.004, 0.02)),
    }
    k = plant["spring_n_per_m"]
    for attempt in range(1, 2001):
        plant["mass_kg"] = float(rng.uniform(0.5e-3, 2e-3))
        m = plant["mass_kg"]
        kp = rng.uniform(300.0, 1500.0)
        ki = rng.uniform(1000.0, 8000.0)
        zeta = rng.uniform(*KD_DAMPING_RANGE)
        kd = max(2 * zeta * math.sqrt(m * (kp + k)) - plant["damping_n_s_per_m"], 0.05)
        loop = {
            "structure": "parallel PID, derivative on the measurement (first-order filter), "
                         "set-point weight b on P, integrator clamped (anti-windup)",
            "controller_rate_hz": fc,
            "kp_n_per_m": float(kp),
            "ki_n_per_m_s": float(ki),
            "kd_n_s_per_m": float(kd),
            "setpoint_weight_b": float(rng.uniform(0.0, 1.0)),
            "derivative_filter_hz": float(min(rng.uniform(*DERIVATIVE_FILTER_HZ), fc / 4.0)),
            "drive_bandwidth_hz": float(rng.uniform(300.0, 1500.0)),
            "drive_damping_ratio": float(rng.uniform(0.5, 0.8)),
            "transport_delay_ticks": 1,
            "drive_limit_n": DRIVE_LIMIT_N,
            "draw_attempts": attempt,
        }
        ok, damping, gm, pm = loop_acceptable(plant, loop, contact)
        if ok:
            loop["min_pole_damping_ratio"] = damping
            loop["gain_margin"] = gm
            loop["phase_margin_deg"] = pm
            return plant, loop
    raise RuntimeError("no stable loop found")


# ----------------------------------------------------------------------------------------
# Protocol


class _Builder:
    """Accumulates the setpoint and the normal-load command at the controller ticks."""

    def __init__(self, fc):
        self.fc = fc
        self.x = [np.zeros(1)]
        self.n = [np.zeros(1)]
        self.xc = 0.0
        self.nc = 0.0
        self.t = 0.0
        self.log = []

    def _ticks(self, duration):
        count = max(int(round(duration * self.fc)), 1)
        return (np.arange(1, count + 1) / self.fc), count / self.fc

    def path(self, duration, fn):
        """fn(tau) with tau in (0, duration] -> position offset from the start."""
        tau, real = self._ticks(duration)
        xs = self.xc + fn(tau * duration / real)
        self.x.append(xs)
        self.n.append(np.full(len(tau), self.nc))
        self.xc = float(xs[-1])
        self.t += real

    def hold(self, duration):
        self.path(duration, lambda tau: np.zeros_like(tau))

    def load_ramp(self, target, duration):
        tau, real = self._ticks(duration)
        self.n.append(self.nc + (target - self.nc) * tau / real)
        self.x.append(np.full(len(tau), self.xc))
        self.nc = float(target)
        self.t += real

    def stroke_const(self, dist, speed):
        d = abs(dist) / speed
        s = math.copysign(1.0, dist)
        self.path(d, lambda tau: s * speed * tau)

    def stroke_ramp(self, dist, v1, v2):
        """Speed changes linearly from v1 to v2 along the stroke."""
        d = 2 * abs(dist) / (v1 + v2)
        s = math.copysign(1.0, dist)
        self.path(d, lambda tau: s * (v1 * tau + (v2 - v1) * tau * tau / (2 * d)))

    def stroke_step(self, dist, v1, v2, split):
        """Speed v1 over the first `split` of the stroke, then v2."""
        d1 = abs(dist) * split / v1
        d2 = abs(dist) * (1 - split) / v2
        s = math.copysign(1.0, dist)
        l1 = abs(dist) * split

        def fn(tau):
            return s * np.where(tau <= d1, v1 * tau, l1 + v2 * (tau - d1))
        self.path(d1 + d2, fn)

    def sine(self, amplitude, freq, periods):
        d = periods / freq
        self.path(d, lambda tau: amplitude * np.sin(2 * math.pi * freq * tau))

    def arrays(self):
        return np.concatenate(self.x), np.concatenate(self.n)


def build_protocol(rng, fc, duration_target):
    """Triangle reciprocation, speed ramps and steps within strokes, sine oscillation,
    small presliding oscillation and holds of varied length, at 2 or 3 loads."""
    n_levels = int(rng.integers(2, 4))
    while True:
        loads = np.sort(np.exp(rng.uniform(math.log(0.5e-3), math.log(10e-3), n_levels)))
        if loads[-1] / loads[0] >= 2.0:
            break
    loads = [float(v) for v in rng.permutation(loads)]
    b = _Builder(fc)
    summary = {"segments": {}, "speeds_um_per_s": [], "holds_s": [], "strokes_um": []}

    def count(kind):
        summary["segments"][kind] = summary["segments"].get(kind, 0) + 1

    def target_end(stroke):
        """Signed stroke that keeps the setpoint within the window (shortened if no
        direction has room for all of it)."""
        room_up, room_down = WINDOW_M - b.xc, WINDOW_M + b.xc
        if room_up >= stroke and room_down >= stroke:
            return stroke if rng.uniform() < 0.5 else -stroke
        if room_up >= room_down:
            return min(stroke, room_up)
        return -min(stroke, room_down)

    def hold():
        d = _log_uniform(rng, 0.2, 8.0)
        summary["holds_s"].append(round(d, 3))
        b.hold(d)

    kinds = ["triangle", "ramp", "step", "sine", "presliding"]
    queue = [str(kd) for kd in rng.permutation(kinds)]   # every kind once, then at random
    b.hold(0.5)
    per_level = duration_target / n_levels
    for li, load in enumerate(loads):
        b.load_ramp(load, rng.uniform(0.5, 1.0))
        b.hold(rng.uniform(1.0, 2.0))
        level_end = b.t + per_level - 4.5
        first = True
        while first or b.t < level_end - 3.0:
            first = False
            kind = queue.pop(0) if queue else kinds[rng.integers(len(kinds))]
            count(kind)
            if kind == "triangle":
                stroke = rng.uniform(4e-6, 14e-6)
                speed = _log_uniform(rng, 2e-6, 40e-6)
                cycles = int(min(rng.integers(2, 4), max(1, 20.0 * speed / (2 * stroke))))
                # start from one end of a centred stroke
                start = -stroke / 2 if rng.uniform() < 0.5 else stroke / 2
                b.stroke_const(start - b.xc, 10e-6) if abs(start - b.xc) > 1e-9 else None
                for _ in range(cycles):
                    b.stroke_const(-2 * start, speed)
                    b.stroke_const(2 * start, speed)
                summary["speeds_um_per_s"].append(round(speed * 1e6, 3))
                summary["strokes_um"].append(round(stroke * 1e6, 3))
            elif kind == "ramp":
                for _ in range(int(rng.integers(2, 4))):
                    stroke = rng.uniform(4e-6, 12e-6)
                    lo, hi = _log_uniform(rng, 0.5e-6, 4e-6), _log_uniform(rng, 10e-6, 40e-6)
                    v1, v2 = (lo, hi) if rng.uniform() < 0.5 else (hi, lo)
                    b.stroke_ramp(target_end(stroke), v1, v2)
                    summary["strokes_um"].append(round(stroke * 1e6, 3))
                    hold()
            elif kind == "step":
                for _ in range(int(rng.integers(2, 4))):
                    stroke = rng.uniform(6e-6, 14e-6)
                    v1 = _log_uniform(rng, 1.5e-6, 40e-6)
                    ratio = _log_uniform(rng, 3.0, 10.0)
                    v2 = v1 * ratio if v1 * ratio <= 40e-6 else v1 / ratio
                    b.stroke_step(target_end(stroke), v1, v2, rng.uniform(0.4, 0.6))
                    summary["strokes_um"].append(round(stroke * 1e6, 3))
                    hold()
            elif kind == "sine":
                amp = rng.uniform(2e-6, 6e-6)
                if abs(b.xc) > WINDOW_M - amp:
                    b.stroke_const(-b.xc, 10e-6)
                vpk = _log_uniform(rng, 5e-6, 30e-6)
                b.sine(amp, vpk / (2 * math.pi * amp), int(rng.integers(2, 5)))
                hold()
            else:  # presliding: small oscillation about a rest point
                amp = rng.uniform(0.1e-6, 0.4e-6)
                b.sine(amp, rng.uniform(0.5, 2.0), int(rng.integers(3, 7)))
                hold()
        if li == len(loads) - 1:
            b.stroke_const(-b.xc, 10e-6) if abs(b.xc) > 1e-9 else None
            b.hold(1.0)
            b.load_ramp(0.0, 0.5)
            b.hold(0.5)
    x_ref, n_cmd = b.arrays()
    summary["speeds_um_per_s"] = sorted(set(summary["speeds_um_per_s"]))
    protocol = {
        "description": "per load level: triangle reciprocation (strokes 4-14 µm, 2-40 µm/s), "
                       "strokes with the speed ramped continuously (0.5-4 <-> 10-40 µm/s), "
                       "strokes with a speed step (x3-x10) at mid-stroke, sine oscillation "
                       "(2-6 µm, 5-30 µm/s peak), small presliding oscillation (0.1-0.4 µm, "
                       "0.5-2 Hz), holds 0.2-8 s (log-uniform); loads changed at rest",
        "loads_n": loads,
        "segment_counts": summary["segments"],
        "holds_s": summary["holds_s"],
        "duration_s": float((len(x_ref) - 1) / fc),
    }
    return x_ref, n_cmd, protocol


# ----------------------------------------------------------------------------------------
# Normal axis and noise


def normal_load(rng, n_cmd, fc):
    """Open-loop normal axis: electronics settle in 5 ms, then the transducer springs
    absorb a growing part eps of the commanded load with time constant tau (creep)."""
    eps = float(rng.uniform(0.01, 0.04))
    tau = float(rng.uniform(2.0, 8.0))
    tc = 1.0 / fc
    a1 = math.exp(-tc / 5e-3)
    settled = lfilter([1 - a1], [1, -a1], n_cmd, zi=[a1 * n_cmd[0]])[0]
    a2 = math.exp(-tc / tau)
    absorbed = lfilter([eps * (1 - a2)], [1, -a2], settled, zi=[a2 * eps * settled[0]])[0]
    # the load cannot pull: below zero the tip has left the surface
    return np.maximum(settled - absorbed, 0.0), {"absorbed_fraction": eps, "creep_time_constant_s": tau,
                                "settling_time_constant_s": 5e-3}


def position_noise(rng, count, fc):
    """Sensor noise on the position at the controller ticks: a white part band-limited by
    the demodulator's low-pass and a 1/f-like part (four first-order Gauss-Markov
    processes with corners a decade apart, equal variance)."""
    white_rms = float(rng.uniform(1e-9, 2e-9))
    coloured_rms = math.sqrt(POSITION_NOISE_M ** 2 - white_rms ** 2)
    demod_hz = float(min(rng.uniform(*DEMODULATOR_HZ), fc / 4.0))
    a = math.exp(-2 * math.pi * demod_hz / fc)
    w = lfilter([1 - a], [1, -a], rng.standard_normal(count))
    w *= white_rms / math.sqrt((1 - a) / (1 + a))
    corners = [0.01, 0.1, 1.0, 10.0]
    coloured = np.zeros(count)
    for fcn in corners:
        ac = math.exp(-2 * math.pi * fcn / fc)
        e = rng.standard_normal(count) * math.sqrt(1 - ac * ac)
        first = rng.standard_normal()
        coloured += lfilter([1.0], [1, -ac], e, zi=[ac * first])[0]
    coloured *= coloured_rms / math.sqrt(len(corners))
    return w + coloured, {
        "position_white_rms_m": white_rms, "position_demodulator_hz": demod_hz,
        "position_coloured_rms_m": coloured_rms, "position_coloured_corners_hz": corners,
        "position_total_rms_m": POSITION_NOISE_M, "position_quantisation_m": POSITION_STEP_M,
    }


# ----------------------------------------------------------------------------------------
# Effects


def draw_effect(effect, seed, strength):
    rng = np.random.default_rng([_stable_salt(FAMILY + effect), seed])
    s = float(strength)
    if effect == "none":
        return {}
    if effect == "dwell_stiction":
        return {"beta": s, "age_exponent_p": 0.3, "age_reference_s": 1.0,
                "slip_memory_m": float(rng.uniform(0.2e-6, 1.0e-6)),
                "initial_age_s": 10.0}
    if effect == "frictional_lag":
        return {"delay_s": s}
    if effect == "velocity_strengthening":
        return {"c": s, "v_a_m_per_s": float(rng.uniform(2e-6, 8e-6))}
    if effect == "load_dependence":
        return {"adhesive_force_at_1mN_n": s * 1e-6, "exponent": 2.0 / 3.0,
                "on_levels": "added to both Fc and Fs"}
    if effect == "position_periodic":
        return {"a1": s, "a2": 0.5 * s, "wavelength_m": float(rng.uniform(1.5e-6, 4e-6)),
                "phase1_rad": float(rng.uniform(0, 2 * math.pi)),
                "phase2_rad": float(rng.uniform(0, 2 * math.pi))}
    if effect == "direction_asymmetry":
        return {"a": s, "favoured_direction": int(1 if rng.uniform() < 0.5 else -1),
                "on_levels": "Coulomb level only; static level Fs unchanged"}
    if effect == "tilt_offset":
        return {"angle_deg": s * (1 if rng.uniform() < 0.5 else -1)}
    if effect == "drift":
        return {"thermal_amplitude_n": s * 1e-6 * (1 if rng.uniform() < 0.5 else -1),
                "thermal_time_constant_s": float(rng.uniform(20.0, 60.0)),
                "random_walk_n_per_sqrt_s": s * 1e-6 / 20.0,
                "random_walk_seed": int(rng.integers(2 ** 31))}
    if effect == "presliding_hysteresis":
        return {"w": s, "elements": 4,
                "breakaway_displacements_m": [float(v) for v in
                                              np.geomspace(0.02e-6, 0.3e-6, 4)
                                              * rng.uniform(0.7, 1.4)]}
    if effect == "backlash":
        return {"gap_width_m": s * 1e-6, "soft_stiffness_n_per_m": float(rng.uniform(100, 300)),
                "hard_stiffness_n_per_m": 3e4,
                "gap_damping_n_s_per_m": float(rng.uniform(0.3, 1.0))}
    if effect == "rate_state":
        return {"a": s, "b": s * float(rng.uniform(0.5, 0.8)),
                "law": "slip (Ruina)", "v_star_m_per_s": 5e-6,
                "dc_m": float(rng.uniform(1e-6, 3e-6)), "v_floor_m_per_s": 0.2e-6}
    if effect == "oov_humidity_cycle":
        return {"amplitude": s, "period_s": float(rng.uniform(40.0, 90.0)),
                "phase_rad": float(rng.uniform(0, 2 * math.pi))}
    raise ValueError(f"unknown effect {effect!r}; known: {', '.join(EFFECTS)}")


def friction_levels(contact, effect, ep, n_true, fc):
    """Coulomb and static levels at each tick (N)."""
    fcoul = contact["mu_c"] * n_true
    fstat = contact["mu_s"] * n_true
    if effect == "load_dependence":
        adh = ep["adhesive_force_at_1mN_n"] * np.power(np.maximum(n_true, 0.0) / 1e-3, 2.0 / 3.0)
        fcoul = fcoul + adh
        fstat = fstat + adh
    elif effect == "oov_humidity_cycle":
        t = np.arange(len(n_true)) / fc
        f = 1.0 + ep["amplitude"] * np.sin(2 * math.pi * t / ep["period_s"] + ep["phase_rad"])
        fcoul = fcoul * f
        fstat = fstat * f
    return fcoul, fstat


# ----------------------------------------------------------------------------------------
# Simulation


def simulate(plant, contact, loop, x_ref, n_true, x_noise, effect, ep, decimation,
             max_substep=MAX_SUBSTEP_S, position_step=POSITION_STEP_M):
    """Run the loop; return arrays at every `decimation`-th controller tick.

    Per tick: the controller reads the quantised noisy position, computes its command,
    which the drive stage receives one tick later. The plant is integrated in n_sub
    sub-steps per tick: the drive stage exactly (zero-order hold on its input), the
    mechanics by the trapezoidal rule with the friction linearised in the end speed, the
    bristle state z exactly for the sub-step's mean speed (exponential relaxation).
    """
    fc = loop["controller_rate_hz"]
    tc = 1.0 / fc
    n_sub = max(1, int(math.ceil(tc / max_substep - 1e-9)))
    h = tc / n_sub
    m, k, c = plant["mass_kg"], plant["spring_n_per_m"], plant["damping_n_s_per_m"]
    s0, s1, fv = contact["sigma0_n_per_m"], contact["sigma1_n_s_per_m"], contact["fv_n_s_per_m"]
    vs = contact["vs_m_per_s"]
    kp, ki, kd = loop["kp_n_per_m"], loop["ki_n_per_m_s"], loop["kd_n_s_per_m"]
    bw = loop["setpoint_weight_b"]
    tf = 1.0 / (2 * math.pi * loop["derivative_filter_hz"])
    umax = loop["drive_limit_n"]
    wd = 2 * math.pi * loop["drive_bandwidth_hz"]
    zd = loop["drive_damping_ratio"]
    phi_d = expm(np.array([[0.0, 1.0], [-wd * wd, -2 * zd * wd]]) * h)
    d11, d12, d21, d22 = (float(phi_d[0, 0]), float(phi_d[0, 1]),
                          float(phi_d[1, 0]), float(phi_d[1, 1]))

    fcoul_a, fstat_a = friction_levels(contact, effect, ep, n_true, fc)
    fcoul_l = fcoul_a.tolist()
    fstat_l = fstat_a.tolist()
    n_l = n_true.tolist()
    xr_l = x_ref.tolist()
    xn_l = x_noise.tolist()
    count = len(xr_l)

    # effect switches
    e_dwell = effect == "dwell_stiction"
    e_lag = effect == "frictional_lag"
    e_vs = effect == "velocity_strengthening"
    e_rip = effect == "position_periodic"
    e_asym = effect == "direction_asymmetry"
    e_tilt = effect == "tilt_offset"
    e_ms = effect == "presliding_hysteresis"
    e_bl = effect == "backlash"
    e_rs = effect == "rate_state"
    if e_dwell:
        beta, p_age, th_ref, d_age = (ep["beta"], ep["age_exponent_p"], ep["age_reference_s"],
                                      ep["slip_memory_m"])
        age = ep["initial_age_s"]
        # the age follows the net slip over 20 ms windows: the loop's nanometre jitter
        # (µm/s at the tick scale) is not slip that renews the contact
        age_ticks = max(1, int(round(0.02 * fc)))
        age_x0 = 0.0
    if e_lag:
        lag_ticks = max(1, int(round(ep["delay_s"] * fc)))
        vbuf = [0.0] * (lag_ticks + 1)
    if e_vs:
        c_vs, v_a = ep["c"], ep["v_a_m_per_s"]
    if e_rip:
        q1 = 2 * math.pi / ep["wavelength_m"]
        a1, a2, ph1, ph2 = ep["a1"], ep["a2"], ep["phase1_rad"], ep["phase2_rad"]
    if e_asym:
        a_as = ep["a"] * ep["favoured_direction"]
    if e_tilt:
        tt = math.tan(math.radians(ep["angle_deg"]))
    if e_ms:
        w_ms = ep["w"]
        ms_disp = ep["breakaway_displacements_m"]
        n_el = len(ms_disp)
        xi = [0.0] * n_el
    if e_bl:
        gap_b = 0.5 * ep["gap_width_m"]
        k_soft, k_hard = ep["soft_stiffness_n_per_m"], ep["hard_stiffness_n_per_m"]
        c_gap = ep["gap_damping_n_s_per_m"]
        delta = 0.0
        v_tip = 0.0
    if e_rs:
        a_rs, b_rs, vstar, dc, vfl = (ep["a"], ep["b"], ep["v_star_m_per_s"], ep["dc_m"],
                                      ep["v_floor_m_per_s"])
        psi = 0.0  # ln(V* theta / Dc), steady at V*

    exp = math.exp
    log = math.log
    sin = math.sin
    asinh = math.asinh
    floor = math.floor
    qx = position_step

    x = v = z = 0.0
    p = q = 0.0          # plate force and its rate
    integ = dterm = 0.0
    u_prev = 0.0
    xq_prev = 0.0
    fl = 0.0             # contact friction force (LuGre), for diagnostics / tilt coupling
    mh = m / h
    kh2 = k * h * 0.5

    nrec = (count + decimation - 1) // decimation
    rec_xq = [0.0] * nrec
    rec_f = [0.0] * nrec
    rec_x = [0.0] * nrec
    rec_v = [0.0] * nrec
    rec_fl = [0.0] * nrec
    j = 0

    diverged_at = None
    for i in range(count):
        if not -1.0 < x < 1.0:
            diverged_at = i
            break
        xq = floor((x + xn_l[i]) / qx + 0.5) * qx
        if i % decimation == 0:
            rec_xq[j] = xq
            rec_f[j] = p - k * xq
            rec_x[j] = x
            rec_v[j] = v
            rec_fl[j] = fl
            j += 1
        # controller
        xr = xr_l[i]
        dterm = (tf * dterm - kd * (xq - xq_prev)) / (tf + tc)
        xq_prev = xq
        err = xr - xq
        u = kp * (bw * xr - xq) + integ + dterm
        if u > umax:
            u = umax
        elif u < -umax:
            u = -umax
        if not ((u >= umax and err > 0) or (u <= -umax and err < 0)):
            integ += ki * tc * err
            if integ > umax:
                integ = umax
            elif integ < -umax:
                integ = -umax
        w_in = u_prev       # one tick of transport delay
        u_prev = u

        fcl = fcoul_l[i]
        fsl = fstat_l[i]
        nl = n_l[i]
        x_tick = x
        if e_dwell:
            fsl = max(fcl, fsl * (1.0 + beta * ((age / th_ref) ** p_age - 1.0)))
        if e_lag:
            vdel = vbuf[i % (lag_ticks + 1)]
            svd = exp(-abs(vdel) / vs)
        f_ext = 0.0
        if e_tilt:
            f_ext = -nl * tt
        if e_ms:
            w_f = w_ms * fcl
            fcl -= w_f
            fsl -= w_f
            wk = w_f / n_el
            kel = [wk / dd for dd in ms_disp]
            for ie in range(n_el):
                lim = ms_disp[ie]
                if xi[ie] > lim:
                    xi[ie] = lim
                elif xi[ie] < -lim:
                    xi[ie] = -lim
        gmin = 1e-6 * fcl + 1e-12

        for _ in range(n_sub):
            # drive stage, exact for the held input
            ep_ = p - w_in
            p_new = w_in + d11 * ep_ + d12 * q
            q = d21 * ep_ + d22 * q
            fd = 0.5 * (p + p_new) + f_ext
            p = p_new
            if e_rip:
                fd -= nl * (a1 * sin(q1 * x + ph1) + a2 * sin(2 * q1 * x + ph2))
            if e_tilt and nl > 0.0:
                # friction ratio bounded: near zero load a held bristle makes fl/N meaningless
                fr = min(max(-fl / nl, -0.5), 0.5)
                fd -= nl * (fr - tt) * fr * tt / (1.0 + fr * tt)
            if e_ms:
                fms = 0.0
                for ie in range(n_el):
                    fms += kel[ie] * xi[ie]
                fd -= fms

            vt = v_tip if e_bl else v
            av = vt if vt >= 0.0 else -vt
            if e_asym:
                fce = fcl * (1.0 + a_as) if vt > 0.0 else (fcl * (1.0 - a_as) if vt < 0.0 else fcl)
            else:
                fce = fcl
            if e_lag:
                g = fce + (fsl - fce) * svd
            else:
                g = fce + (fsl - fce) * exp(-av / vs)
            if e_vs:
                g += c_vs * fcl * asinh(av / v_a)
            if e_rs:
                g += fcl * (a_rs * log((av + vfl) / vstar) + b_rs * psi)
            if g < gmin:
                g = gmin
            r = av * s0 / g
            rh = r * h
            if rh < 1e-9:
                e = 1.0 - rh
                phi = h
            else:
                e = exp(-rh)
                phi = (1.0 - e) / r
            aa = s0 * z * (1.0 + e) * 0.5 + s1 * z * (e - 1.0) / h
            bb = s0 * phi * 0.5 + s1 * phi / h + fv

            if not e_bl:
                dd_ = kh2 + c + bb
                un = (mh * v + fd - k * x - aa - dd_ * v * 0.5) / (mh + dd_ * 0.5)
                vm = 0.5 * (v + un)
                dx = h * vm
                x += dx
                z = z * e + phi * vm
                fl = aa + bb * vm
                v = un
                vt = vm
            else:
                # plate against the holder force H(delta), explicit
                if delta > gap_b:
                    hf = k_soft * gap_b + k_hard * (delta - gap_b)
                elif delta < -gap_b:
                    hf = -k_soft * gap_b + k_hard * (delta + gap_b)
                else:
                    hf = k_soft * delta
                hf += c_gap * (v - v_tip)
                dd_ = kh2 + c
                un = (mh * v + fd - k * x - hf - dd_ * v * 0.5) / (mh + dd_ * 0.5)
                vm = 0.5 * (v + un)
                dx = h * vm
                x += dx
                v = un
                # massless tip: H(delta + h (vm - vt)) = aa + bb vt, H piecewise linear
                vt_sol = 0.0
                seg = 1 if delta > gap_b else (-1 if delta < -gap_b else 0)
                for _try in range(3):
                    if seg == 0:
                        kk, h0 = k_soft, 0.0
                    else:
                        kk, h0 = k_hard, seg * (k_soft - k_hard) * gap_b
                    # kk*(delta + h*(vm - vt)) + h0 + c_gap*(vm - vt) = aa + bb*vt
                    vt_sol = ((kk * (delta + h * vm) + h0 + c_gap * vm - aa)
                              / (bb + kk * h + c_gap))
                    dn = delta + h * (vm - vt_sol)
                    seg_n = 1 if dn > gap_b else (-1 if dn < -gap_b else 0)
                    if seg_n == seg:
                        break
                    seg = seg_n
                delta = dn
                z = z * e + phi * vt_sol
                fl = aa + bb * vt_sol
                v_tip = vt_sol
                vt = vt_sol
            if e_rs:
                avt = vt if vt >= 0.0 else -vt
                if avt > 0.0:
                    psi_ss = -log(avt / vstar)
                    psi = psi_ss + (psi - psi_ss) * exp(-avt * h / dc)
            if e_ms:
                for ie in range(n_el):
                    nxi = xi[ie] + dx
                    lim = ms_disp[ie]
                    xi[ie] = lim if nxi > lim else (-lim if nxi < -lim else nxi)
        if e_dwell and (i + 1) % age_ticks == 0:
            tw = age_ticks * tc
            sp = abs(x - age_x0) / tw
            age_x0 = x
            if sp > 0.0:
                ass = d_age / sp
                age = ass + (age - ass) * exp(-sp * tw / d_age)
            else:
                age += tw
        if e_lag:
            vbuf[(i + lag_ticks) % (lag_ticks + 1)] = (x - x_tick) / tc
    return {
        "x_meas": np.array(rec_xq),
        "force_clean": np.array(rec_f),
        "x_true": np.array(rec_x),
        "v_true": np.array(rec_v),
        "contact_friction": np.array(rec_fl),
        "n_sub": n_sub,
        "substep_s": h,
        "diverged_at_tick": diverged_at,
    }


# ----------------------------------------------------------------------------------------
# File


def design(seed):
    """Everything drawn from the seed alone: instrument, contact, loop, protocol, noise."""
    rng = np.random.default_rng([_stable_salt(FAMILY), seed])
    rate = int(RECORD_RATES_HZ[rng.integers(len(RECORD_RATES_HZ))])
    duration = float(rng.uniform(min(60.0, MAX_DURATION_S[rate] - 6.0), MAX_DURATION_S[rate]))
    contact = draw_contact(rng)
    fc = draw_controller_rate(rng, rate)
    plant, loop = draw_plant_and_loop(rng, contact, fc)
    x_ref, n_cmd, protocol = build_protocol(rng, fc, duration)
    n_true, normal_info = normal_load(rng, n_cmd, fc)
    x_noise, noise_info = position_noise(rng, len(x_ref), fc)
    noise_info.update({
        "force_white_rms_n": FORCE_NOISE_N, "force_quantisation_n": FORCE_STEP_N,
        "normal_white_rms_n": NORMAL_NOISE_N, "normal_quantisation_n": NORMAL_STEP_N,
    })
    readout_seed = int(rng.integers(2 ** 31))
    return {
        "rate_hz": rate, "contact": contact, "plant": plant, "loop": loop,
        "protocol": protocol, "x_ref": x_ref, "n_true": n_true, "normal_axis": normal_info,
        "x_noise": x_noise, "noise": noise_info, "readout_seed": readout_seed,
    }


def make_record(effect, seed, strength=None, noise=True, max_substep=MAX_SUBSTEP_S,
                quantise=True):
    """The record and its truth. noise=False, quantise=False, max_substep: for checks
    (effect contributions without noise, convergence of the integration)."""
    if effect not in EFFECTS:
        raise ValueError(f"unknown effect {effect!r}; known: {', '.join(EFFECTS)}")
    s = DEFAULT_STRENGTH[effect] if strength is None else float(strength)
    d = design(seed)
    fc = d["loop"]["controller_rate_hz"]
    dec = fc // d["rate_hz"]
    ep = draw_effect(effect, seed, s)
    x_noise = d["x_noise"] if noise else np.zeros_like(d["x_noise"])
    sim = simulate(d["plant"], d["contact"], d["loop"], d["x_ref"], d["n_true"], x_noise,
                   effect, ep, dec, max_substep,
                   POSITION_STEP_M if quantise else 1e-15)
    idx = np.arange(0, len(d["x_ref"]), dec)
    t = idx / fc
    force = sim["force_clean"].copy()
    n_rec = d["n_true"][idx].copy()
    rr = np.random.default_rng([d["readout_seed"], 7])
    if effect == "drift":
        force += drift_series(t, ep)
    if noise:
        force += FORCE_NOISE_N * rr.standard_normal(len(t))
        force = np.round(force / FORCE_STEP_N) * FORCE_STEP_N
        n_rec += NORMAL_NOISE_N * rr.standard_normal(len(t))
        n_rec = np.round(n_rec / NORMAL_STEP_N) * NORMAL_STEP_N
    truth = {
        "family": FAMILY,
        "effect": effect,
        "in_vocabulary": IN_VOCABULARY[effect],
        "strength": s,
        "strength_unit": STRENGTH_UNIT[effect],
        "seed": int(seed),
        "rate_hz": d["rate_hz"],
        "contact": d["contact"],
        "effect_parameters": ep,
        "loop": dict(d["loop"], **{"plant": d["plant"], "plant_substep_s": sim["substep_s"],
                                   "recorded_force": "plate force - k x_meas (k calibrated "
                                                     "exactly), sampled at every "
                                                     f"{dec}-th controller tick"}),
        "noise": dict(d["noise"], **{"normal_axis": d["normal_axis"]}),
        "protocol": d["protocol"],
    }
    return {"t": t, "x": sim["x_meas"], "x_ref": d["x_ref"][idx], "force": force,
            "normal": n_rec, "truth": truth, "sim": sim, "design": d}


def drift_series(t, ep):
    """Thermal settling of the force reading plus a random walk (added to the record)."""
    th = ep["thermal_amplitude_n"] * (1.0 - np.exp(-t / ep["thermal_time_constant_s"]))
    rng = np.random.default_rng(ep["random_walk_seed"])
    dt = np.diff(t, prepend=t[0])
    walk = np.cumsum(ep["random_walk_n_per_sqrt_s"] * np.sqrt(dt) * rng.standard_normal(len(t)))
    return th + walk


def write(out_dir, effect, seed, strength=None):
    """Write the record and its truth; return the CSV path."""
    rec = make_record(effect, seed, strength)
    os.makedirs(out_dir, exist_ok=True)
    stem = os.path.join(out_dir, f"{FAMILY}_{effect}_seed{seed}")
    data = np.column_stack([rec["t"], rec["x"], rec["x_ref"], rec["force"], rec["normal"]])
    with open(stem + ".csv", "w") as f:
        f.write("t_s,x_m,x_ref_m,force_N,normal_N\n")
        np.savetxt(f, data, fmt=["%.6f", "%.4e", "%.6e", "%.4e", "%.6e"], delimiter=",")
    with open(stem + ".json", "w") as f:
        json.dump(rec["truth"], f, indent=1)
        f.write("\n")
    return stem + ".csv"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out_dir")
    ap.add_argument("effect", choices=EFFECTS)
    ap.add_argument("seed", type=int)
    ap.add_argument("--strength", type=float, default=None)
    args = ap.parse_args()
    print(write(args.out_dir, args.effect, args.seed, args.strength))


if __name__ == "__main__":
    main()
