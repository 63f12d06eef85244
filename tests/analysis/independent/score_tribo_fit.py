#!/usr/bin/python3
"""Scores tribo-fit on the independent generator (transducer_sim.py).

For every effect x seed: generate the file, run the contract command
(no velocity column), and tabulate the first accepted effect, everything
accepted, the unexplained residual, and whether the 95 % intervals of the
base parameters (value +- 1.96 std_error) cover the truth. Files for which
the model form matches the truth (clean files) enter the coverage count.

usage: score_tribo_fit.py TRIBO_FIT OUT_DIR [--effects a,b] [--seeds 1,2,3] [--jobs 2] [--extra "ARGS"] [--reuse]
(--reuse: take reports already in OUT_DIR instead of running again)
"""
import concurrent.futures as cf
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import transducer_sim  # noqa: E402

VOCABULARY = ["dwell_stiction", "frictional_lag", "velocity_strengthening", "load_dependence",
              "position_periodic", "direction_asymmetry", "tilt_offset", "drift",
              "presliding_hysteresis", "backlash", "rate_state"]


def run_one(tribo_fit, out_dir, effect, seed, extra, reuse=False):
    stem = os.path.join(out_dir, f"{effect}_seed{seed}")
    if reuse and os.path.exists(stem + ".report.json"):
        return effect, seed, json.load(open(stem + ".json")), json.load(open(stem + ".report.json")), ""
    csv = transducer_sim.write(out_dir, effect, seed)
    truth = json.load(open(csv[:-4] + ".json"))
    cmd = [tribo_fit, "diagnose", csv, "--time", "t_s", "--position", "x_m", "--force", "force_N",
           "--normal", "normal_N", "--reference", "x_ref_m", "--json"] + extra
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        return effect, seed, truth, None, r.stderr
    report = json.loads(r.stdout)
    with open(csv[:-4] + ".report.json", "w") as f:
        f.write(r.stdout)
    return effect, seed, truth, report, ""


def truth_strength(effect, truth):
    """The injected strength in the analysis's parameter, where the two forms
    share one (the generator writes each effect in its own form): None
    otherwise."""
    strength = truth.get("strength")
    if strength is None:
        return None
    if effect == "velocity_strengthening":  # levels x (1 + c ln v): c mu_c per e-fold in mu
        return strength * truth["contact"]["mu_c"]
    if effect in ("frictional_lag", "direction_asymmetry", "tilt_offset", "backlash"):
        return strength
    if effect == "rate_state":  # levels x (1 + a ln v + ...): a mu_c in mu, the analysis's rs_a
        return truth["rate_state"]["a_mu"]
    return None


def minimum_detectable(report, effect):
    """The report's minimum detectable strength of a rejected effect: (value or inf, unit,
    parameter, withheld) or None; withheld: why no figure is given, or None."""
    for r in report.get("rejected_effects", []):
        if r["name"] == effect and "minimum_detectable" in r:
            m = r["minimum_detectable"]
            return (m["value"] if m["value"] is not None else float("inf")), m["unit"], m["parameter"], m.get("withheld")
    return None


def coverage(report, truth):
    """(covered, total) for the base parameters whose truth is known, 95 %."""
    c = truth["contact"]
    true = {"mu_c": c["mu_c"], "mu_s": c["mu_s"], "vs": c["vs_m_per_s"], "sigma0": c["sigma0_n_per_m"],
            "sigma1": c["sigma1_n_s_per_m"], "Fv": c["fv_n_s_per_m"], "offset": 0.0}
    covered = total = 0
    detail = []
    for p in report["final_model"]["parameters"]:
        if p["name"] in true and p.get("std_error") not in (None, "NaN") and not p.get("fixed"):
            se = p["std_error"]
            if se is None or se != se:
                continue
            ok = abs(p["value"] - true[p["name"]]) <= 1.96 * se
            covered += ok
            total += 1
            detail.append(f'{p["name"]}:{"ok" if ok else "MISS"}({p["value"]:.4g}+-{se:.2g} vs {true[p["name"]]:.4g})')
    return covered, total, detail


def main():
    args = sys.argv[1:]
    opts = {"--effects": ",".join(transducer_sim.EFFECTS), "--seeds": "3,17,41", "--jobs": "2", "--extra": ""}
    reuse = "--reuse" in args
    if reuse:
        args.remove("--reuse")
    for k in list(opts):
        if k in args:
            i = args.index(k)
            opts[k] = args[i + 1]
            del args[i:i + 2]
    tribo_fit, out_dir = args
    effects = opts["--effects"].split(",")
    seeds = [int(s) for s in opts["--seeds"].split(",")]
    extra = opts["--extra"].split()
    jobs = []
    with cf.ThreadPoolExecutor(int(opts["--jobs"])) as pool:
        for e in effects:
            for s in seeds:
                jobs.append(pool.submit(run_one, tribo_fit, out_dir, e, s, extra, reuse))
    right_first = {e: 0 for e in effects}
    below_detection = {e: 0 for e in effects}
    cov_ok = cov_n = 0
    for job in jobs:
        effect, seed, truth, report, err = job.result()
        if report is None:
            print(f"{effect:24s} seed {seed:3d}: FAILED {err.strip()[:200]}")
            continue
        accepted = [a["name"] for a in report["accepted_effects"]]
        first = accepted[0] if accepted else "-"
        expected = "-" if effect in ("none", "wear_in") else effect
        right = first == expected
        if effect == "wear_in":
            right = not accepted and report.get("unexplained") is not None
        right_first[effect] += right
        if effect == "none":
            ok, n, detail = coverage(report, truth)
            cov_ok += ok
            cov_n += n
        else:
            detail = []
        heldout = report["error_before"]["heldout"]["nrmse"], report["error_after"]["heldout"]["nrmse"]
        unexplained = report.get("unexplained") or ""
        print(f"{effect:24s} seed {seed:3d}: {'RIGHT' if right else 'wrong'} accepted {accepted} "
              f"held-out NRMSE {heldout[0]:.3f}->{heldout[1]:.3f} unexplained: {unexplained[:90]}")
        if detail:
            print("    coverage " + " ".join(detail))
        mds = minimum_detectable(report, effect) if effect in VOCABULARY and not right else None
        if mds:
            injected = truth_strength(effect, truth)
            below = injected is not None and injected < mds[0]
            below_detection[effect] += below
            claim = (f"no figure given ({mds[3][:60]})" if mds[3]
                     else f"reported not identifiable below {mds[2]} = {mds[0]:.3g} {mds[1]}")
            print(f"    {effect} {claim}; injected "
                  + (f"{injected:.3g}" if injected is not None else "(another form)")
                  + (": below detection" if below else ""))
    print()
    for e in effects:
        note = (f" (+{below_detection[e]} missed below the reported minimum detectable strength, or with none given)"
                if below_detection[e] else "")
        print(f"{e:24s} right {right_first[e]}/{len(seeds)}{note}")
    total = sum(right_first.values())
    print(f"total right {total}/{len(effects) * len(seeds)}; base-parameter coverage on clean files "
          f"{cov_ok}/{cov_n}")


if __name__ == "__main__":
    main()
