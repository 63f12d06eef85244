#!/usr/bin/python3
"""ctest: tribo-fit on the independent generator, the contract command
without a velocity column. Each case is a file of the generator
(transducer_sim.py; effect, seed, strength) and what the report must say:

- clean, seed 3: the position noise floor is estimated at 10 nm +- 15 %, the
  segmentation finds the protocol's 24 passes (+- 4), each pass starts from
  the force measured at rest (chosen on held-out passes: the 10 nm position
  noise hides the nanometres a stopping contact relaxes over), the base
  LuGre fit's held-out NRMSE is below 0.03, nothing is accepted, and sigma0's
  95 % interval, with the motion model's systematic part in it, holds the
  truth;
- wear_in, seed 3 (friction growing with the total slip, outside the
  vocabulary): nothing accepted, the residual reported as unexplained;
- clean, seeds 1 and 2: nothing accepted (seed 1's frictional lag is refused
  as possibly the motion estimate's);
- position_periodic, seed 7 (3.4 periods on a pass): named first with its
  period within 5 %;
- dwell_stiction, seeds 1, 3 and 10: named first (seed 10 by the peak after
  the longest hold, seed 3 on a base whose mu_s stays below 2);
- presliding_hysteresis, seed 2, with --motion-estimator rts_loop_force: the
  servo's yield found (-5e-5 m/N +- 10 %), the pass start from the force at
  rest chosen on the lower final held-out error, presliding named first;
- drift, seed 5: drift named first and tilt_offset refused by the held-out
  gates (a drift in time with loads that rise with time fits like a tilt in
  sliding); drift, seed 2: the final model is past its bounds, so the report
  says it does not describe the record, names nothing and gives no minimum
  detectable figure; tilt_offset seed 2 and drift seed 8 (the spline's knot
  count chosen by the record) named first;
- frictional_lag, seed 2: named first (each held-out pass votes with the
  candidate's change there);
- velocity_strengthening at three times the default: seed 7 not accepted with
  a minimum detectable strength above the injected one, set by injection and
  recovery; seeds 8 and 10 named first; seed 9 a final model past its bounds
  (said not to describe the record); seed 4, fitted with the opposite sign,
  gives no figure that calls the missed strength identifiable; at six times
  the default seed 3 is past its bounds and seed 8 gives no such figure;
- clean with speed steps within the passes, seed 3: nothing accepted;
  rate_state at the generator's default, seed 2: named first;
- holds of minutes: a sample creep (seed 1, 0.3 nm/s) named drift in the form
  "creep under a stuck contact" at 0.15-0.45 nm/s; the clean record with the
  same holds names nothing.

usage: check_tribo_fit.py TRIBO_FIT WORK_DIR [PART ...]
       (the parts: clean, effects, strengthening, protocols; default all; ctest runs
       each as its own test, side by side)
"""
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import transducer_sim  # noqa: E402


def diagnose(tribo_fit, work, effect, seed=3, extra=(), strength=None):
    return run_contract(tribo_fit, transducer_sim.write(work, effect, seed, strength), extra)


def run_contract(tribo_fit, csv, extra=()):
    cmd = [tribo_fit, "diagnose", csv, "--time", "t_s", "--position", "x_m", "--force", "force_N",
           "--normal", "normal_N", "--reference", "x_ref_m", "--json", *extra]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"tribo-fit failed on {csv}: {r.stderr}")
    return json.loads(r.stdout)


def check_first(tribo_fit, work, effect, seed, failures, strength=None):
    """The injected effect is accepted first on the file of this seed."""
    accepted = [a["name"] for a in diagnose(tribo_fit, work, effect, seed, strength=strength)["accepted_effects"]]
    if accepted[:1] != [effect]:
        failures.append(f"{effect} seed {seed}: accepted {accepted}, {effect} not first")
    print(f"{effect}, seed {seed}: accepted {accepted}")


def check_not_describing(tribo_fit, work, effect, seed, failures, strength=None):
    """The final model of this file is past its bounds (a static level more than
    5 times the Coulomb level): the report says it does not describe the record,
    names nothing, and lists the injected effect as rejected with that reason."""
    report = diagnose(tribo_fit, work, effect, seed, strength=strength)
    accepted = [a["name"] for a in report["accepted_effects"]]
    reasons = report["base_model"]["not_describing_reasons"]
    mine = next((r for r in report["rejected_effects"] if r["name"] == effect), {})
    if report["base_model"]["describes_record"] or accepted or not any("more than 5 times" in r for r in reasons) \
            or "does not describe the record" not in mine.get("reason", ""):
        failures.append(f"{effect} seed {seed}: describes_record {report['base_model']['describes_record']}, "
                        f"accepted {accepted}, reasons {reasons}")
    print(f"{effect}, seed {seed}: accepted {accepted}; not describing: {'; '.join(reasons)[:100]}")


def check_no_overclaim(tribo_fit, work, seed, c, failures):
    """Velocity strengthening at c per e-fold on this seed: named first, or
    no figure below the injected c mu_c calls the missed strength identifiable."""
    report = diagnose(tribo_fit, work, "velocity_strengthening", seed, strength=c)
    truth = json.load(open(os.path.join(work, f"velocity_strengthening_seed{seed}.json")))
    injected = c * truth["contact"]["mu_c"]
    accepted = [a["name"] for a in report["accepted_effects"]]
    vs = next((r for r in report["rejected_effects"] if r["name"] == "velocity_strengthening"), None)
    m = (vs or {}).get("minimum_detectable") or {}
    if accepted[:1] != ["velocity_strengthening"] and m.get("value") is not None and m["value"] < injected:
        failures.append(f"velocity_strengthening c {c} seed {seed}: not named ({accepted}), figure {m['value']} below the injected {injected:.4g}")
    print(f"velocity_strengthening c {c}, seed {seed}: accepted {accepted}, figure {m.get('value')}, withheld: {(m.get('withheld') or '')[:60]}")


def part_clean(tribo_fit, work, failures):
    """The clean files, wear-in, position-periodic friction and a dwell file whose
    base must stay physical."""
    report = diagnose(tribo_fit, work, "none")
    noise = report["input"].get("position_noise_m", 0)
    if not 8.5e-9 <= noise <= 11.5e-9:
        failures.append(f"position noise floor {noise} m, expected 10 nm +- 15 %")
    passes = report["segmentation"]["passes"]
    if not 20 <= passes <= 28:
        failures.append(f"{passes} passes, the protocol has 24")
    if "rts" not in report["input"].get("motion_estimator", ""):
        failures.append(f"motion estimator {report['input'].get('motion_estimator')}")
    start = report["base_model"].get("pass_start_state", {}).get("chosen")
    if start != "from the force at rest":
        failures.append(f"pass start state {start!r}, expected 'from the force at rest'")
    nrmse = report["error_before"]["heldout"]["nrmse"]
    if not nrmse < 0.03:
        failures.append(f"base held-out NRMSE {nrmse:.3f}, expected below 0.03")
    accepted = [a["name"] for a in report["accepted_effects"]]
    if accepted:
        failures.append(f"the clean file accepted {accepted}")
    print(f"clean: noise {noise:.3g} m, {passes} passes, base held-out NRMSE {nrmse:.3f}, accepted {accepted}")
    # The contact stiffness's 95 % interval holds the truth with the motion
    # model's systematic part in it (its statistical part alone is too narrow
    # for the motion estimate's bias).
    truth = json.load(open(os.path.join(work, "none_seed3.json")))["contact"]["sigma0_n_per_m"]
    sigma0 = next(p for p in report["final_model"]["parameters"] if p["name"] == "sigma0")
    if "motion_systematic" not in sigma0 or not abs(sigma0["value"] - truth) <= 1.96 * sigma0["std_error"]:
        failures.append(f"sigma0 {sigma0}: its 95 % interval misses the truth {truth:.0f} N/m")
    print(f"clean: sigma0 {sigma0['value']:.0f} +- {sigma0['std_error']:.0f} N/m "
          f"(motion model {sigma0.get('motion_systematic', float('nan')):.0f}), truth {truth:.0f}")

    report = diagnose(tribo_fit, work, "wear_in")
    accepted = [a["name"] for a in report["accepted_effects"]]
    if accepted or not report.get("unexplained"):
        failures.append(f"wear_in: accepted {accepted}, unexplained {report.get('unexplained')!r}")
    print(f"wear_in: accepted {accepted}; unexplained: {(report.get('unexplained') or '')[:100]}")

    accepted = [a["name"] for a in diagnose(tribo_fit, work, "none", 2)["accepted_effects"]]
    if accepted:
        failures.append(f"the clean seed-2 file accepted {accepted}")
    print(f"clean, seed 2: accepted {accepted}")
    # The clean seed-1 file fits a 13 ms frictional lag that passes on its
    # statistical error alone and stands at 1.7 standard errors with the
    # motion model's part: refused as possibly the motion estimate's.
    report = diagnose(tribo_fit, work, "none", 1)
    accepted = [a["name"] for a in report["accepted_effects"]]
    lag = next(r for r in report["rejected_effects"] if r["name"] == "frictional_lag")
    if accepted or "may be the motion estimate's" not in lag["reason"]:
        failures.append(f"the clean seed-1 file accepted {accepted}; frictional_lag: {lag['reason'][:120]}")
    print(f"clean, seed 1: accepted {accepted}; frictional_lag {lag['reason'][:80]}")
    # A 1.46 um period on 5 um passes (3.4 periods): the signature's peak
    # search must reach periods longer than a fifth of a pass.
    report = diagnose(tribo_fit, work, "position_periodic", 7)
    period = json.load(open(os.path.join(work, "position_periodic_seed7.json")))["period_m"]
    first = report["accepted_effects"][:1]
    length = next((p["value"] for p in first[0]["parameters"] if p["name"] == "periodic_length"), None) if first else None
    if not first or first[0]["name"] != "position_periodic" or not length or abs(length / period - 1) > 0.05:
        failures.append(f"position_periodic seed 7 (period {period:.3g} m): accepted {[a['name'] for a in report['accepted_effects']]}, length {length}")
    print(f"position_periodic, seed 7: period {period:.3g} m, found {length}")
    # dwell_stiction, seed 3: the lowest-residual base start is a Stribeck spike (mu_s 3.5e12
    # at 15 nm/s) that takes the dwell peaks up; the base must keep a
    # physical static level.
    report = diagnose(tribo_fit, work, "dwell_stiction", 3)
    accepted = [a["name"] for a in report["accepted_effects"]]
    mu_s = next(p["value"] for p in report["base_model"]["parameters"] if p["name"] == "mu_s")
    if accepted[:1] != ["dwell_stiction"] or not mu_s < 2:
        failures.append(f"dwell_stiction seed 3: accepted {accepted}, base mu_s {mu_s:.3g}")
    print(f"dwell_stiction, seed 3: accepted {accepted}, base mu_s {mu_s:.3g}")


def part_effects(tribo_fit, work, failures):
    """Presliding with the loop force, drift against tilt, the drift knots and the lag."""
    # The loop model driven by the force too: the generator's servo yields by
    # -1/20 000 m/N. On the presliding seed-2 file the pass start is chosen on
    # the final models: from the force at rest, with the lower held-out pass
    # error, and presliding named.
    report = diagnose(tribo_fit, work, "presliding_hysteresis", 2, ("--motion-estimator", "rts_loop_force"))
    response = report["input"].get("loop_force_response_m_per_n", 0)
    if not -5.5e-5 <= response <= -4.5e-5:
        failures.append(f"loop force response {response} m/N, the generator's -5e-5 +- 10 %")
    start = report["base_model"].get("pass_start_state", {})
    accepted = [a["name"] for a in report["accepted_effects"]]
    if start.get("chosen") != "from the force at rest" or not (
            start.get("final_heldout_pass_rms_state_from_rest", 1) < start.get("final_heldout_pass_rms_modelled_holds", 0)):
        failures.append(f"presliding seed 2 with the force taps: pass start {start}")
    if accepted[:1] != ["presliding_hysteresis"]:
        failures.append(f"presliding seed 2 with the force taps: accepted {accepted}")
    print(f"presliding_hysteresis, seed 2, rts_loop_force: response {response:.3g} m/N, accepted {accepted}")

    # A reading that drifts in time, with loads that rise with time, fits
    # like a tilt in sliding. Seed 5: drift is accepted first, and the tilt
    # fitted after it predicts the held-out passes worse (the held-out gates
    # refuse it). Seed 2: the rounds accept drift, on a final model past its
    # bounds, which names nothing. The tilt file of seed 2 keeps its tilt.
    report = diagnose(tribo_fit, work, "drift", 5)
    accepted = [a["name"] for a in report["accepted_effects"]]
    tilt = next((r for r in report["rejected_effects"] if r["name"] == "tilt_offset"), {})
    held_out_refusal = tilt.get("reason", "").startswith("fitted but did not clearly help on held-out data")
    if accepted[:1] != ["drift"] or "tilt_offset" in accepted or not held_out_refusal:
        failures.append(f"drift seed 5: accepted {accepted}; tilt_offset: {tilt.get('reason', '')[:160]}")
    print(f"drift, seed 5: accepted {accepted}; tilt_offset {tilt.get('reason', '')[:100]}")
    report = diagnose(tribo_fit, work, "drift", 2)
    accepted = [a["name"] for a in report["accepted_effects"]]
    # Its final model keeps a Stribeck spike past the bounds (static level
    # over 5 times the Coulomb level): the report says the model does not
    # describe the record and names no effect (the rounds' drift is listed
    # as rejected with that reason), and gives no minimum detectable figure.
    describes = report["base_model"]["describes_record"]
    drift = next((r for r in report["rejected_effects"] if r["name"] == "drift"), {})
    vs = next((r for r in report["rejected_effects"] if r["name"] == "velocity_strengthening"), {})
    if describes or accepted or "does not describe the record" not in drift.get("reason", "") \
            or vs.get("minimum_detectable") or not report.get("unexplained"):
        failures.append(f"drift seed 2: describes_record {describes}, accepted {accepted}, drift: "
                        f"{drift.get('reason', '')[:120]}")
    print(f"drift, seed 2: describes_record {describes}, accepted {accepted}; drift: {drift.get('reason', '')[:100]}")
    check_first(tribo_fit, work, "tilt_offset", 2, failures)
    # The drift spline's knot count from the record (leave-one-pass-out
    # cross-validation; 8 intervals here): with 12 fixed ones the drift file
    # of seed 8 takes direction_asymmetry first.
    check_first(tribo_fit, work, "drift", 8, failures)

    # A lag acts at the few onsets; counted by samples, the held-out passes it
    # does not touch would outvote it (74 % against the 75 % bar on seed 2):
    # each pass votes with the candidate's change there.
    check_first(tribo_fit, work, "frictional_lag", 2, failures)


def part_strengthening(tribo_fit, work, failures):
    """Velocity strengthening at three and six times the default."""
    # Velocity strengthening at three times the default (c = 0.09 per e-fold):
    # on seed 7 it is fitted and not accepted. The linearised figure (0.0049
    # per e-fold in mu) lies below the injected c mu_c (0.0095); injection and
    # recovery sets the reported figure (0.0188), so the report does not call
    # the injected strength identifiable.
    report = diagnose(tribo_fit, work, "velocity_strengthening", 7, strength=0.09)
    truth = json.load(open(os.path.join(work, "velocity_strengthening_seed7.json")))
    injected = 0.09 * truth["contact"]["mu_c"]
    vs = next((r for r in report["rejected_effects"] if r["name"] == "velocity_strengthening"), None)
    m7 = (vs or {}).get("minimum_detectable") or {}
    figure = m7.get("value")
    if vs is None or figure is None or figure < injected or m7.get("bound_by") != "injection and recovery":
        failures.append(f"velocity_strengthening x3 seed 7: figure {figure} ({m7.get('bound_by')}) below the injected {injected:.4g}"
                        f" while not accepted ({(vs or {}).get('reason', 'accepted')[:120]})")
    print(f"velocity_strengthening x3, seed 7: figure {figure}, injected {injected:.4g}")

    # Seed 8: named first (it needs the hold band from the record's noise
    # floor and the pass start chosen on the final models).
    check_first(tribo_fit, work, "velocity_strengthening", 8, failures, strength=0.09)
    # Seed 9: the rounds take it, on a final model whose static level is a
    # spike (mu_s 3.2e16): the report says the model does not describe the
    # record and names nothing.
    check_not_describing(tribo_fit, work, "velocity_strengthening", 9, failures, strength=0.09)
    # Seed 4: fitted with the opposite sign (-0.0018) at -16.6 % held-out, and
    # refused; a trial that takes the velocity dependence the other way
    # withholds the minimum detectable figure (injection and recovery gives
    # 0.0024, which would call the missed 0.0106 identifiable).
    check_no_overclaim(tribo_fit, work, 4, 0.09, failures)

    # On seed 10 the fit leaves mu_s at 1e-4 beside mu_c 0.137: the bound on
    # the strength is taken against the friction level (against the static
    # level alone it would refuse a 34 % held-out gain).
    check_first(tribo_fit, work, "velocity_strengthening", 10, failures, strength=0.09)

    # At six times the default (c = 0.18) the base fit takes the rise into a
    # Stribeck curve that rises (seed 3: mu_s 0.082 below mu_c 0.117), and
    # the candidate fitted from there found 0.005 +- 0.005 of the injected
    # 0.015. The rise moved into the log term is its second start; the final
    # model keeps a static spike (mu_s 3.2e8): it does not describe the
    # record, and nothing is named.
    check_not_describing(tribo_fit, work, "velocity_strengthening", 3, failures, strength=0.18)
    # Seed 8 at six times is missed: its final model's curve still rises
    # (mu_s 0.113 below mu_c 0.162), and such a model withholds the
    # velocity-strengthening figure (0.0012 by injection and recovery, which
    # would call the missed 0.0168 identifiable).
    check_no_overclaim(tribo_fit, work, 8, 0.18, failures)


def part_protocols(tribo_fit, work, failures):
    """Dwell stiction after rests, speed steps within passes, rate-and-state, and
    holds of minutes (creep)."""
    check_first(tribo_fit, work, "dwell_stiction", 1, failures)
    # Seed 10: the term's asymptote dwell_dFs (0.155 +- 0.066 with the
    # motion model's part: 2.3 errors) trades off against dwell_time; the
    # peak after the longest hold, which the record determines, clears the
    # strength gate.
    check_first(tribo_fit, work, "dwell_stiction", 10, failures)

    # Speed steps within the passes (the protocol of the generator's
    # rate_state files): a clean record accepts nothing.
    csv = transducer_sim.write(work, "none", 3, steps=True)
    report = run_contract(tribo_fit, csv)
    accepted = [a["name"] for a in report["accepted_effects"]]
    if accepted:
        failures.append(f"none with speed steps, seed 3: accepted {accepted}")
    print(f"none with speed steps, seed 3: accepted {accepted}")

    # Rate-and-state friction at the generator's default (a = 0.05 of the
    # levels, b = 1.2 a, Dc = 1 um): named first. It needs the holds held
    # (a hold band from the record's noise floor): a bristle run through the
    # holds on the smoother's velocity refuses it.
    check_first(tribo_fit, work, "rate_state", 2, failures)

    # Holds of minutes (the generator's --holds protocol): a creep of the
    # sample (0.3 nm/s, seed 1) is named a creep under the stuck contact
    # from the holds. Its speed comes out low (0.23 nm/s): the generator's
    # plain LuGre contact has no elastic range, a creep that loads the held
    # force further does so at c (1 - |z|/g), and the pass model's sigma0 is
    # 13 % below the generator's. The clean record with the same holds names
    # nothing.
    report = run_contract(tribo_fit, transducer_sim.write(work, "creep", 1))
    creep = report.get("creep_in_holds") or {}
    accepted = [a["name"] for a in report["accepted_effects"]]
    speed = creep.get("creep_speed_m_per_s") or 0.0
    if "drift" not in accepted or creep.get("form") != "creep under a stuck contact" or not 0.15e-9 <= speed <= 0.45e-9:
        failures.append(f"creep seed 1: accepted {accepted}, form {creep.get('form')}, speed {speed}")
    print(f"creep, seed 1: accepted {accepted}, form {creep.get('form')}, speed {speed:.3g} m/s (0.3e-9 injected)")
    report = run_contract(tribo_fit, transducer_sim.write(work, "none", 1, holds=True))
    accepted = [a["name"] for a in report["accepted_effects"]]
    if accepted:
        failures.append(f"none with holds of minutes, seed 1: accepted {accepted}")
    print(f"none with holds of minutes, seed 1: accepted {accepted}")


PARTS = {"clean": part_clean, "effects": part_effects, "strengthening": part_strengthening,
         "protocols": part_protocols}


def main():
    tribo_fit, work = sys.argv[1:3]
    names = sys.argv[3:] or list(PARTS)
    unknown = [n for n in names if n not in PARTS]
    if unknown:
        sys.exit(f"unknown part(s) {unknown}: the parts are {list(PARTS)}")
    failures = []
    for name in names:
        # Each part in its own directory: ctest runs the parts side by side.
        PARTS[name](tribo_fit, os.path.join(work, name), failures)
    if failures:
        sys.exit("; ".join(failures))


if __name__ == "__main__":
    main()
