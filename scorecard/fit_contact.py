#!/usr/bin/python3
"""Fits a split of the scorecard: the parameters it declares fitted, on its fit
rows only, and writes the split's config (scorecard/splits.json).

  /usr/bin/python3 scorecard/fit_contact.py --split NAME [--evaluations N] [--dwell-evaluations N]

Starts from config/instruments/fitted_contact.textproto (the contact law the
default-law splits refit: direct effect on the tip's velocity, slip law, dwell
term) with the split's "fixed" fields, then fits
its parameter groups in this order, each on the rows tribo-scorecard --split
NAME marks "fit" (seed 1):

  loop_gains  ki = mean of eq. 28's 2 Fs / (v ts^2) over the fit rows of
              Table 5.1 at 4 µm/s and above (at 0.2 µm/s the tip creeps before
              the peak); kp = ki x mean(dl / v) - k over those at 18 µm/s and
              above (eq. 33: the lag time of the I-PD loop is (kp + k) / ki).
              From the dissertation's values alone, no simulation.
  contact     a, b, Dc, V* of the rate-and-state law and the elasto-plastic
              breakaway ratio r: Nelder-Mead (scipy) in log-parameters (r
              through a logit) on the sum of squared natural-log errors of the
              fit rows' Fs, ts and dl, their ds and velocity overshoots at half
              weight, plus a penalty when steady friction changes from 0.2 to
              10 µm/s by less than 0 or more than 5 % (§4.4.3). The Coulomb
              level follows from mu(13.5 µm/s) = 0.0996 (§4.4), the rest state
              is Dc / V*.
  dwell       Armstrong's dwell gain and time constant: Nelder-Mead in
              log-parameters on the squared point errors of the fit rows of
              Fig. 4.22 (the full figure: about 9 s of CPU per evaluation).

--law slip_rate fits the contact of config/instruments/slip_rate_contact/
instead (docs/simulated_instrument.md, "The default contact: the slip-rate law"): the direct
effect on the slip rate, Dieterich's ageing law, no separate dwell term. Its
"contact" group is a, b, Dc, V* and r with a and b held inside the literature's
range relative to the friction level (SLIP_RATE_COEFF_RANGE, through a scaled
logit) and Dc inside the contact's length scale (SLIP_RATE_DC_RANGE_M);
"dwell" is off (the state's own ageing replaces it). Writes
config/instruments/slip_rate_contact/NAME.textproto.

A group the split does not fit must be fixed by it (its "fixed" entries):
otherwise its values would be the fitted contact's, fitted on every row. Prints each
evaluation; writes config/instruments/cross_validation/NAME.textproto (the
split's "config") with the fitted values, the fit rows and the loss in its
header. Parameter groups are data below (GROUPS): a new contact law's
parameters are a new group (its config fields, start values and transforms).
"""
import argparse
import datetime
import json
import math
import os
import subprocess
import sys
import tempfile
import textwrap

import numpy as np
from scipy.optimize import minimize

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCORECARD = os.path.join(ROOT, "build", "scorecard", "tribo-scorecard")
# The base every split is written from: the fitted contact's law and start
# values; --law slip_rate sets its own law fields on it.
BASE = os.path.join(ROOT, "config", "instruments", "fitted_contact.textproto")
SPLITS = os.path.join(ROOT, "scorecard", "splits.json")
MAKE_CONFIG = os.path.join(ROOT, "scorecard", "make_config.py")
MU_13_5 = 0.0996          # §4.4: Amontons mu at 13.5 µm/s
LATERAL_SPRING_N_PER_M = 116.0  # config/tribod.textproto, fitted_contact.textproto: the transducer's lateral spring k


def logit(p):
    return math.log(p / (1 - p))


def sigmoid(u):
    return 1 / (1 + math.exp(-u))


# The fitted groups: their config fields, start values (the fitted contact's), and
# how the optimiser sees each one (log: positive; logit: in (0, 1)).
GROUPS = {
    "loop_gains": {
        "fields": ["controller.lateral_displacement.kp", "controller.lateral_displacement.ki"],
    },
    "contact": {
        "fields": ["sim.friction.rate_state.direct_coeff", "sim.friction.rate_state.state_coeff",
                   "sim.friction.rate_state.memory_length_m", "sim.friction.rate_state.reference_velocity_m_per_s",
                   "sim.friction.breakaway_ratio"],
        "start": [0.0218378, 0.0191429, 1.88265e-07, 2.11532e-06, 0.917056],
        "transforms": ["log", "log", "log", "log", "logit"],
    },
    "dwell": {
        "fields": ["sim.friction.dwell_stiction.gain", "sim.friction.dwell_stiction.time_constant_s",
                   "sim.friction.dwell_stiction.enabled"],
        "start": [0.15, 200.0],
        "transforms": ["log", "log"],
    },
}


# The slip-rate contact (--law slip_rate). a and b relative to the friction
# level mu = 0.0996: 0.01-0.05 (rock, a and b 0.005-0.015 at mu 0.6-0.85:
# Dieterich 1979, Ruina 1983, Marone 1998; multicontact polymer and paper
# interfaces, A and B of order 0.01 at mu 0.3-0.5: Heslot et al. 1994,
# Baumberger and Caroli 2006). Dc between a tenth and the whole of the contact
# radius at the scorecard's loads (1.0-2.7 µm, 500-9810 µN; Hertz, R = 50 µm,
# E* = 18 GPa): 0.27-2.73 µm.
SLIP_RATE_COEFF_RANGE = (0.01 * MU_13_5, 0.05 * MU_13_5)
SLIP_RATE_DC_RANGE_M = (0.273e-6, 2.73e-6)
SLIP_RATE_BREAKAWAY_RANGE = (0.80, 0.99)  # r; the config allows at most 0.99
SLIP_RATE_FRESH_STATE_S = 0.01  # phi_0: the age of a fresh contact, small beside every rest (>= 2 s)
SLIP_RATE_LAW = [
    "sim.friction.rate_state.direct_effect_rate=RATE_STATE_DIRECT_SLIP_RATE",
    "sim.friction.rate_state.law=RATE_STATE_AGEING",
    "sim.friction.dwell_stiction.enabled=false",
]


def bounded_to_unit(x, lo, hi):
    return (x - lo) / (hi - lo)


def unit_to_bounded(u, lo, hi):
    return lo + u * (hi - lo)


def slip_rate_contact_assignments(q):
    """q: the optimiser's view (a, b, Dc, r in (0, 1) of their ranges; V*)."""
    a, b, dc, v_star, r = slip_rate_values(q)
    coulomb = MU_13_5 - (a - b) * math.log1p(13.5e-6 / v_star)
    return SLIP_RATE_LAW + [
        "sim.friction.rate_state.enabled=true",
        f"sim.friction.rate_state.direct_coeff={a:.6g}",
        f"sim.friction.rate_state.state_coeff={b:.6g}",
        f"sim.friction.rate_state.memory_length_m={dc:.6g}",
        f"sim.friction.rate_state.reference_velocity_m_per_s={v_star:.6g}",
        f"sim.friction.rate_state.initial_state_s={SLIP_RATE_FRESH_STATE_S:.6g}",
        f"sim.friction.breakaway_ratio={r:.6g}",
        f"sim.friction.static_coeff={coulomb:.6g}",
        f"sim.friction.coulomb_coeff={coulomb:.6g}",
    ]


def slip_rate_values(q):
    return [unit_to_bounded(q[0], *SLIP_RATE_COEFF_RANGE), unit_to_bounded(q[1], *SLIP_RATE_COEFF_RANGE),
            unit_to_bounded(q[2], *SLIP_RATE_DC_RANGE_M), q[3], unit_to_bounded(q[4], *SLIP_RATE_BREAKAWAY_RANGE)]


# Start: a = 0.04 mu, b = 0.035 mu (a - b within §4.4.3's flatness), Dc 1 µm,
# V* and r the fitted contact's.
SLIP_RATE_START = [bounded_to_unit(0.04 * MU_13_5, *SLIP_RATE_COEFF_RANGE),
                   bounded_to_unit(0.035 * MU_13_5, *SLIP_RATE_COEFF_RANGE),
                   bounded_to_unit(1.0e-6, *SLIP_RATE_DC_RANGE_M), 2.11532e-06,
                   bounded_to_unit(0.917056, *SLIP_RATE_BREAKAWAY_RANGE)]


def contact_assignments(p):
    a, b, dc, v_star, r = p
    coulomb = MU_13_5 - (a - b) * math.log1p(13.5e-6 / v_star)
    return [
        "sim.friction.rate_state.enabled=true",
        f"sim.friction.rate_state.direct_coeff={a:.6g}",
        f"sim.friction.rate_state.state_coeff={b:.6g}",
        f"sim.friction.rate_state.memory_length_m={dc:.6g}",
        f"sim.friction.rate_state.reference_velocity_m_per_s={v_star:.6g}",
        f"sim.friction.rate_state.initial_state_s={dc / v_star:.6g}",
        f"sim.friction.breakaway_ratio={r:.6g}",
        f"sim.friction.static_coeff={coulomb:.6g}",
        f"sim.friction.coulomb_coeff={coulomb:.6g}",
    ]


def dwell_assignments(p):
    gain, gamma = p
    return ["sim.friction.dwell_stiction.enabled=true", f"sim.friction.dwell_stiction.gain={gain:.6g}",
            f"sim.friction.dwell_stiction.time_constant_s={gamma:.6g}"]


def scorecard_rows(split, assignments, groups, seed=1):
    """tribo-scorecard --split SPLIT on the base config with the assignments."""
    with tempfile.NamedTemporaryFile("w", suffix=".textproto", delete=False) as f:
        path = f.name
    try:
        subprocess.run([sys.executable, MAKE_CONFIG, BASE, path, *assignments], check=True)
        cmd = [SCORECARD, "--config", path, "--split", split, "--seed", str(seed), "--json"]
        for g in groups:
            cmd += ["--group", g]
        out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    finally:
        os.unlink(path)
    return json.loads(out)["rows"]


def fit_rows_of(rows, quantities):
    return [r for r in rows if r["role"] == "fit" and r["quantity"] in quantities]


def fit_loop_gains(split, assignments):
    # The fit rows' dissertation values (any config gives them).
    rows = scorecard_rows(split, assignments, ["table_5_1"])
    by = {(r["quantity"], r["load_uN"], r["velocity_um_per_s"]): r["dissertation"]
          for r in fit_rows_of(rows, ("Fs", "ts", "dl"))}
    mki = [2 * fs * 1e-6 / (v * 1e-6 * by[("ts", load, v)] ** 2)
           for (q, load, v), fs in by.items() if q == "Fs" and v >= 4 and ("ts", load, v) in by]
    lag_s = [dl / v for (q, load, v), dl in by.items() if q == "dl" and v >= 18]
    if not mki or not lag_s:
        sys.exit(f"fit_contact.py: split {split}: loop_gains needs fit rows of Table 5.1's Fs and ts at >= 4 µm/s "
                 f"and dl at >= 18 µm/s")
    ki = float(np.mean(mki))
    kp = ki * float(np.mean(lag_s)) - LATERAL_SPRING_N_PER_M
    print(f"loop_gains: ki = mean of {len(mki)} eq. 28 values = {ki:.1f} N/(m s); lag time {np.mean(lag_s):.4f} s "
          f"over {len(lag_s)} rows: kp = {kp:.1f} N/m", flush=True)
    return [f"controller.lateral_displacement.kp={kp:.6g}", f"controller.lateral_displacement.ki={ki:.6g}"], \
        {"kp": kp, "ki": ki, "eq28_rows": len(mki), "lag_rows": len(lag_s)}


def nelder_mead(name, transforms, start, loss, evaluations, xatol=1e-3, fatol=1e-4, simplex_step=None, shown=None):
    def unpack(u):
        return [math.exp(x) if t == "log" else sigmoid(x) for x, t in zip(u, transforms)]
    u0 = np.array([math.log(x) if t == "log" else logit(x) for x, t in zip(start, transforms)])
    best = [math.inf, None]

    def f(u):
        p = unpack(u)
        value = loss(p)
        if value < best[0]:
            best[0], best[1] = value, p
        print(f"{name} loss {value:9.5f}  " + "  ".join(f"{v:.4g}" for v in (shown(p) if shown else p)), flush=True)
        return value

    options = {"maxfev": evaluations, "xatol": xatol, "fatol": fatol}
    if simplex_step:  # steps of this size in every transformed coordinate (scipy's default: 5 % of each)
        options["initial_simplex"] = np.vstack([u0] + [u0 + simplex_step * e for e in np.eye(len(u0))])
    minimize(f, u0, method="Nelder-Mead", options=options)
    return best[1], best[0]


def contact_loss(split, assignments, to_assignments=contact_assignments, values=lambda p: p):
    def loss(p):
        rows = scorecard_rows(split, assignments + to_assignments(p), ["table_5_1"])
        # §4.4.3: steady friction flat to slightly rising with velocity: the
        # steady mu changes by (a - b) [ln(1 + 10/V*) - ln(1 + 0.2/V*)] from 0.2
        # to 10 µm/s; outside 0 to +5 % of mu it costs as much as a 2.5 % miss
        # is worth in a squared log error of 0.0025 per 2.5 %.
        a, b, _, v_star, _ = values(p)
        rise = (a - b) * (math.log1p(10e-6 / v_star) - math.log1p(0.2e-6 / v_star)) / MU_13_5
        total = (max(0.0, abs(rise - 0.025) - 0.025) / 0.025) ** 2
        for r in fit_rows_of(rows, ("Fs", "ts", "dl", "ds", "overshoot")):
            w = 1.0 if r["quantity"] in ("Fs", "ts", "dl") else 0.5
            if r["simulated"] and r["simulated"] > 0:
                total += w * math.log(r["simulated"] / r["dissertation"]) ** 2
            else:
                total += w * 4.0
        return total
    return loss


def dwell_loss(split, assignments):
    def loss(p):
        rows = scorecard_rows(split, assignments + dwell_assignments(p), ["fig_4_22"])
        spikes = fit_rows_of(rows, ("spike",))
        if not spikes:
            sys.exit(f"fit_contact.py: split {split}: dwell needs fit rows of Fig. 4.22's spikes")
        return sum((r["simulated"] - r["dissertation"]) ** 2 for r in spikes)
    return loss


def load_split(name):
    doc = json.load(open(SPLITS))
    split = next((s for s in doc["splits"] if s["name"] == name), None)
    if split is None:
        sys.exit(f"fit_contact.py: no split '{name}' in {SPLITS}")
    if split.get("refit", True) is False:
        sys.exit(f"fit_contact.py: split '{name}' is not refitted (its 'refit' is false): {split.get('about', '')}")
    fitted = split.get("fitted", [])
    for g in fitted:
        if g not in GROUPS:
            sys.exit(f"fit_contact.py: split {name}: fitted: unknown group '{g}' (known: {', '.join(GROUPS)})")
    fixed_fields = {f["field"] for f in split.get("fixed", [])}
    for g, spec in GROUPS.items():
        if g not in fitted and not fixed_fields & set(spec["fields"]):
            sys.exit(f"fit_contact.py: split {name}: group {g} is neither fitted nor fixed: its values would be the "
                     f"fitted contact's, fitted on every row")
    return split


def without_comments(text):
    """The textproto without its comments (they describe its fit)."""
    out = []
    for line in text.splitlines():
        in_string, cut = False, len(line)
        for i, c in enumerate(line):
            if c == '"':
                in_string = not in_string
            elif c == "#" and not in_string:
                cut = i
                break
        kept = line[:cut].rstrip()
        if kept or not line.strip():
            out.append(kept)
    text = "\n".join(out) + "\n"
    while "\n\n\n" in text:
        text = text.replace("\n\n\n", "\n\n")
    return text.lstrip("\n")


def header(split, report, loss_values, fit_rows, law_flag="", path=""):
    def selector(s):
        return " ".join(f"{k} {v}" for k, v in s.items())
    paragraphs = [
        f'Instrument configuration of the scorecard\'s split "{split["name"]}" (scorecard/splits.json). '
        + split.get("about", ""),
        f"Written by `/usr/bin/python3 scorecard/fit_contact.py {law_flag}--split {split['name']}` "
        f"({datetime.date.today().isoformat()}): config/instruments/fitted_contact.textproto with the fields below "
        "fitted on the split's fit rows only (seed 1). Everything else is that file's, whose comments give the "
        "sources (left out here: they describe its fit). Score it with "
        f"`tribo-scorecard {'--config ' + path + ' ' if law_flag else ''}--split {split['name']}` (docs/simulated_instrument.md, "
        "\"The cross-validated scorecard\").",
        "Fit rows (besides splits.json's calibration rows): " + "; ".join(selector(s) for s in fit_rows) + ".",
    ]
    for f in split.get("fixed", []):
        paragraphs.append(f"Fixed: {f['field']} = {f['value']} ({f['why']}).")
    law = report.get("law")
    if law:
        paragraphs.append("The law (not fitted): " + ", ".join(f"{k} {v}" for k, v in law.items()) + ".")
    for group, values in report.items():
        if group == "law":
            continue
        paragraphs.append(f"Fitted {group}: " + ", ".join(
            f"{k} {v:.6g}" if isinstance(v, float) else f"{k} {v}" for k, v in values.items())
            + (f" (loss {loss_values[group]:.5g})" if group in loss_values else "") + ".")
    out = []
    for p in paragraphs:
        out.append(textwrap.fill(p, width=100, initial_indent="# ", subsequent_indent="# "))
    return "\n#\n".join(out) + "\n\n"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--split", required=True)
    ap.add_argument("--evaluations", type=int, default=80, help="of the contact fit")
    ap.add_argument("--dwell-evaluations", type=int, default=24)
    ap.add_argument("--law", choices=["default", "slip_rate"], default="default",
                    help="slip_rate: the contact of config/instruments/slip_rate_contact/")
    args = ap.parse_args()
    split = load_split(args.split)
    name = split["name"]
    assignments = [f"{f['field']}={f['value']}" for f in split.get("fixed", [])]
    report, losses = {}, {}
    if "loop_gains" in split["fitted"]:
        gains, report["loop_gains"] = fit_loop_gains(name, assignments)
        assignments += gains
    if args.law == "slip_rate":
        # a, b, Dc, r through a logit of their place in their ranges; V* log.
        q, losses["contact"] = nelder_mead("contact", ["logit", "logit", "logit", "log", "logit"], SLIP_RATE_START,
                                           contact_loss(name, assignments, slip_rate_contact_assignments,
                                                        slip_rate_values), args.evaluations,
                                           simplex_step=0.7, shown=slip_rate_values)
        assignments += slip_rate_contact_assignments(q)
        report["contact"] = dict(zip(["a", "b", "Dc_m", "V*_m_per_s", "breakaway_ratio"], slip_rate_values(q)))
        report["law"] = {"direct effect": "slip rate", "state": "ageing law", "dwell term": "off",
                         "a and b range": f"{SLIP_RATE_COEFF_RANGE[0]:.4g}-{SLIP_RATE_COEFF_RANGE[1]:.4g}",
                         "Dc range m": f"{SLIP_RATE_DC_RANGE_M[0]:.3g}-{SLIP_RATE_DC_RANGE_M[1]:.3g}",
                         "fitted on": "the fit rows of the table_5_1 group only (Fig. 4.22's, where declared fit, are not "
                                      "fitted on: no dwell term)"}
        write_config(split, name, assignments, report, losses,
                     os.path.join(ROOT, "config", "instruments", "slip_rate_contact", name + ".textproto"),
                     "--law slip_rate ")
        return
    if "contact" in split["fitted"]:
        spec = GROUPS["contact"]
        p, losses["contact"] = nelder_mead("contact", spec["transforms"], spec["start"],
                                           contact_loss(name, assignments), args.evaluations)
        assignments += contact_assignments(p)
        report["contact"] = dict(zip(["a", "b", "Dc_m", "V*_m_per_s", "breakaway_ratio"], p))
    if "dwell" in split["fitted"]:
        spec = GROUPS["dwell"]
        p, losses["dwell"] = nelder_mead("dwell", spec["transforms"], spec["start"], dwell_loss(name, assignments),
                                         args.dwell_evaluations, xatol=1e-2, fatol=1e-3)
        assignments += dwell_assignments(p)
        report["dwell"] = dict(zip(["gain", "time_constant_s"], p))
    write_config(split, name, assignments, report, losses, os.path.join(ROOT, split["config"]), "")


def write_config(split, name, assignments, report, losses, out, law_flag):
    os.makedirs(os.path.dirname(out), exist_ok=True)
    tmp = out + ".tmp"
    subprocess.run([sys.executable, MAKE_CONFIG, BASE, tmp, *assignments], check=True)
    body = without_comments(open(tmp).read())
    os.unlink(tmp)
    own_rows = json.load(open(SPLITS))["splits"]
    fit_rows = next(s for s in own_rows if s["name"] == name)["fit_rows"]
    open(out, "w").write(header(split, report, losses, fit_rows, law_flag, os.path.relpath(out, ROOT)) + body)
    print("wrote", os.path.relpath(out, ROOT))
    print(" ".join(assignments))


if __name__ == "__main__":
    main()
