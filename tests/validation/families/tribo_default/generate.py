#!/usr/bin/python3
"""Tribo's default simulated instrument as a generator family: the
identification protocol (config/protocols/identification.textproto) run on
config/instruments/fitted_contact.textproto (the contact curve-fitted to Table
5.1 and Fig. 4.22, the default's when the family was frozen: its validation
seeds stay the records they were) with the identification map's base overrides (those
of config/campaigns/identification_reliability.toml: the loop weights its
setpoint in P, no tip tilt and no dwell stiction in the clean plant), and at
most one effect of the sim switched on at a strength. The plant's contact is
that config's (LuGre with elasto-plastic presliding and rate-and-state):
those two laws are in every record (base effects). Loaded segments only, as
the map diagnoses them.

Writes <out>/tribo_default_<effect>_seed<seed>.csv with the columns
t_s,x_m,x_ref_m,force_N,normal_N (lateral position, setpoint, lateral force,
normal force) and a truth .json beside it.

usage: generate.py OUT_DIR EFFECT SEED [--strength S]
"""
import json
import math
import os
import sys
import tomllib

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", "..", ".."))
for p in (os.path.join(ROOT, "client", "python"), os.path.join(ROOT, "build", "python")):
    if p not in sys.path:
        sys.path.insert(0, p)

import numpy as np  # noqa: E402

CONFIG = os.path.join(ROOT, "config", "instruments", "fitted_contact.textproto")
PROTOCOL = os.path.join(ROOT, "config", "protocols", "identification.textproto")
MAP = os.path.join(ROOT, "config", "campaigns", "identification_reliability.toml")

# effect: (the config message that switches it on, its strength field, the strength used by
# default: the config's own value, or the map's where the config leaves it at 0).
SWITCHES = {
    "none": (None, None, 0.0),
    "dwell_stiction": ("sim.friction.dwell_stiction", "gain", 0.15),
    "frictional_lag": ("sim.friction.frictional_lag", "time_constant_s", 0.02),
    "velocity_strengthening": ("sim.friction.velocity_strengthening", "coeff", 0.005),
    "load_dependence": ("sim.friction.load_dependence", "exponent", 0.6667),
    "position_periodic": ("sim.friction.position_periodic", "amplitude", 0.1),
    "direction_asymmetry": ("sim.friction.direction_asymmetry", "ratio", 0.05),
    "tilt_offset": ("sim.tip.tilt_offset", "angle_deg", 1.5),
    "drift": ("sim.sample.drift", "rate_m_per_s", 0.1e-9),
    "backlash": ("sim.tip.backlash", "width_m", 20e-9),
    "oov_wear": ("sim.sample.wear", "steady_state_ratio", 0.85),
}
EFFECTS = list(SWITCHES)
DEFAULT_STRENGTH = {e: s[2] for e, s in SWITCHES.items()}
BASE_EFFECTS = ["rate_state", "presliding_hysteresis"]


def _config(effect, strength):
    from tribo_client import sim
    from tribo_client.campaign.spec import set_field
    config = sim.load_config(CONFIG)
    with open(MAP, "rb") as f:
        for path, value in tomllib.load(f).get("overrides", {}).items():
            set_field(config, path, value)
    message, field, _ = SWITCHES[effect]
    if message:
        set_field(config, message + ".enabled", True)
        set_field(config, f"{message}.{field}", strength)
    return config


def _truth(config, effect, strength, seed, rate_hz):
    f = config.sim.friction
    return {
        "family": "tribo_default", "effect": effect, "in_vocabulary": not effect.startswith("oov_"),
        "strength": strength, "seed": seed, "rate_hz": rate_hz, "base_effects": BASE_EFFECTS,
        # The plant's LuGre part; its rate-and-state law and presliding make the LuGre base
        # the wrong form, so coverage of these is not scored (base_form_matches false).
        "contact": {"mu_c": f.coulomb_coeff, "mu_s": f.static_coeff, "vs_m_per_s": f.stribeck_velocity_m_per_s,
                    "stribeck_exponent": f.stribeck_exponent, "sigma0_n_per_m": f.contact_stiffness_n_per_m,
                    "sigma1_n_s_per_m": f.bristle_damping_n_s_per_m, "fv_n_s_per_m": f.viscous_n_s_per_m},
        "base_form_matches": False,
        "effect_parameters": {SWITCHES[effect][1]: strength} if SWITCHES[effect][0] else {},
        "analysis_strength": _analysis_strength(effect, strength),
        "loop": {"kp": config.controller.lateral_displacement.kp, "ki": config.controller.lateral_displacement.ki,
                 "kd": config.controller.lateral_displacement.kd},
        "noise": {"lateral_force_noise_n": config.sim.sensors.lateral_force_noise_n,
                  "lateral_force_resolution_n": config.sim.sensors.lateral_force_resolution_n,
                  "lateral_position_record_noise_m": config.sim.sensors.lateral_position_record_noise_m},
        "protocol": os.path.relpath(PROTOCOL, ROOT),
    }


def _analysis_strength(effect, strength):
    """The strength in the analysis's own parameter where the sim's form shares it, else None."""
    if effect == "tilt_offset":
        return math.tan(math.radians(strength))
    if effect in ("direction_asymmetry", "frictional_lag", "backlash"):
        return strength
    return None


def write(out_dir, effect, seed, strength=None):
    from tribo_client import sim
    from tribo_client.campaign.worker import _diagnosed_samples
    if effect not in SWITCHES:
        raise ValueError(f"unknown effect {effect!r} (known: {', '.join(EFFECTS)})")
    strength = DEFAULT_STRENGTH[effect] if strength is None else strength
    os.makedirs(out_dir, exist_ok=True)
    config = _config(effect, strength)
    run = sim.simulate(config, PROTOCOL, seed=seed)
    s = _diagnosed_samples(run.samples, {"loaded_segments_only": True})
    stem = os.path.join(out_dir, f"tribo_default_{effect}_seed{seed}")
    data = np.column_stack([s["t"], s["lateral_position"], s["lateral_setpoint"], s["lateral_force"],
                            s["normal_force"]])
    np.savetxt(stem + ".csv", data, delimiter=",", header="t_s,x_m,x_ref_m,force_N,normal_N", comments="",
               fmt="%.10g")
    rate = (len(s["t"]) - 1) / (s["t"][-1] - s["t"][0])
    with open(stem + ".json", "w") as f:
        json.dump(_truth(config, effect, strength, seed, round(rate, 3)), f, indent=1)
    return stem + ".csv"


if __name__ == "__main__":
    args = sys.argv[1:]
    strength = None
    if "--strength" in args:
        k = args.index("--strength")
        strength = float(args[k + 1])
        del args[k:k + 2]
    if len(args) != 3 or args[1] not in SWITCHES:
        sys.exit(__doc__)
    print(write(args[0], args[1], int(args[2]), strength))
