#!/usr/bin/python3
"""Scores `tribo-fit diagnose` on the generator families of a declared split
(tests/validation/splits.toml): for every family x effect x seed, generate
the record, run the README's contract command (no velocity column)

  tribo-fit diagnose FILE --time t_s --position x_m --force force_N
      --normal normal_N --reference x_ref_m --json

and tabulate, per family:
  clean        clean files that name nothing (a family's base effects, which
               its clean plant holds in every record, are not counted);
  named first  each in-vocabulary effect named first, over the files where the
               report calls it identifiable (a miss whose report gives a minimum
               detectable strength above the injected one, comparable in the
               analysis's own parameter, is "below detection" and left out);
  false first  files whose first named effect was not injected (share of all files);
               with --base-model choose the contact laws chosen into the base are
               named first (lugre+elasto_plastic names presliding_hysteresis);
  oov          out-of-vocabulary files reported unexplained with nothing named;
  coverage     the 95 % intervals (value +- 1.96 std_error) of the base parameters
               that hold the truth, on clean files whose plant has the base's form;
  impossible   files whose final model holds a physically impossible value
               (a negative viscous coefficient, stiffness or damping past its 95 %
               interval; a friction coefficient outside (0, 2]) while the report
               does not say the base fails to describe the record.

Writes OUT_DIR/score_<split>.json (per file and per family) and
OUT_DIR/score_<split>.md (the table), and prints the table. With --split
validation no per-file line is printed: the frozen set is scored, never read.

usage: score.py TRIBO_FIT OUT_DIR --split dev|validation [--families a,b]
                [--effects a,b] [--seeds 1,2] [--jobs 2] [--extra "ARGS"] [--reuse]
                [--true-velocity]
(--reuse: take reports already in OUT_DIR instead of running the diagnosis again;
--true-velocity: an oracle, not the contract command: each record gets the
generator's true tip velocity as a column, given as --velocity, which bounds
what a better motion estimate could give; only for families whose generator
returns its true motion, run(effect, seed, traces=True))
"""
import argparse
import concurrent.futures as cf
import importlib.util
import inspect
import json
import math
import os
import statistics
import subprocess
import sys
import time
import tomllib

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
VOCABULARY = ["dwell_stiction", "frictional_lag", "velocity_strengthening", "load_dependence",
              "position_periodic", "direction_asymmetry", "tilt_offset", "drift",
              "presliding_hysteresis", "backlash", "rate_state"]
CONTRACT = ["--time", "t_s", "--position", "x_m", "--force", "force_N", "--normal", "normal_N",
            "--reference", "x_ref_m", "--json"]
SPLIT_NAMES = {"dev": "development", "development": "development", "validation": "validation"}


def load_module(path):
    full = os.path.join(ROOT, path)
    if not os.path.exists(full):
        return None
    name = "family_" + os.path.basename(os.path.dirname(full)) + "_" + os.path.basename(full)[:-3]
    spec = importlib.util.spec_from_file_location(name, full)
    module = importlib.util.module_from_spec(spec)
    sys.path.insert(0, os.path.dirname(full))
    spec.loader.exec_module(module)
    return module


def in_vocabulary(effect, truth):
    if "in_vocabulary" in truth:
        return bool(truth["in_vocabulary"]) and effect != "none"
    return effect in VOCABULARY


def analysis_strength(effect, truth):
    """The injected strength in the analysis's own parameter, where the family's form shares
    one: the truth's `analysis_strength` when the family writes it, else the independent
    generator's forms (tests/analysis/independent/transducer_sim.py) or servo_ipd's
    (servo_ipd_analysis_strength); None otherwise."""
    if "analysis_strength" in truth:
        return truth["analysis_strength"]
    if truth.get("family") == "servo_ipd":
        return servo_ipd_analysis_strength(effect, truth)
    if truth.get("family") not in (None, "independent"):
        return None
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


def servo_ipd_analysis_strength(effect, truth):
    """servo_ipd's strength (tests/validation/families/servo_ipd/README.md, "Effects") in the
    analysis's parameter where the two forms share one, else None. The lag is a pure delay of
    the speed in both; the play's width is the analysis's gap; the asymmetry's fraction is of
    the Coulomb level (the analysis's of both levels); the tilt reads N sin(theta) (tan is
    5.5e-5 larger at the default 0.6 deg); the drift's settling D (1 - exp(-t/tau_d)) changes by D (1 - exp(-T/tau_d))
    over a record of T s (the analysis's figure: the change from start to end); velocity
    strengthening Fc c asinh(|v|/v_a) raises the level by mu_c c per e-fold of speed in the
    friction coefficient where |v| >> v_a (asinh's slope is 0.71 of ln's at v_a, within 5 %
    above 3 v_a: slower strokes see less, so the figure errs towards counting a miss).
    Rate-and-state (b = 1.5 a, where the analysis's figure holds b = a), dwell stiction (both
    levels, faded by slip) and load dependence (Derjaguin's adhesion load against a power law)
    share none."""
    strength = truth.get("strength")
    if strength is None:
        return None
    if effect in ("frictional_lag", "direction_asymmetry", "backlash"):
        return strength
    if effect == "tilt_offset":
        return math.tan(math.radians(strength))
    if effect == "drift":
        duration = truth["protocol"]["duration_s"]
        tau = truth["effect_parameters"]["time_constant_s"]
        return strength * (1.0 - math.exp(-duration / tau))
    if effect == "velocity_strengthening":
        return strength * truth["contact"]["mu_c"]
    return None


def is_below_detection(right, injected, mds):
    """A miss whose report's minimum detectable strength exceeds the injected one, both in the
    analysis's parameter; a miss without either counts as identifiable."""
    return not right and injected is not None and mds is not None and injected < mds


def minimum_detectable(report, effect):
    """The report's minimum detectable strength of a rejected effect (inf when none up to
    the searched strength), or None when the report gives none."""
    for r in report.get("rejected_effects", []):
        if r["name"] == effect and "minimum_detectable" in r:
            m = r["minimum_detectable"]
            if m.get("withheld"):
                return None
            return m["value"] if m["value"] is not None else math.inf
    return None


TRUE_BASE = {"mu_c": "mu_c", "mu_s": "mu_s", "vs": "vs_m_per_s", "sigma0": "sigma0_n_per_m",
             "sigma1": "sigma1_n_s_per_m", "Fv": "fv_n_s_per_m"}


def coverage(report, truth):
    """[(name, covered)] for the base parameters whose truth is known and whose standard
    error is given, 95 %."""
    out = []
    for p in report["final_model"]["parameters"]:
        key = TRUE_BASE.get(p["name"])
        if key is None or p.get("fixed") or key not in truth["contact"]:
            continue
        se = p.get("std_error")
        if se is None or not isinstance(se, (int, float)) or se != se:
            continue
        out.append((p["name"], abs(p["value"] - truth["contact"][key]) <= 1.96 * se))
    return out


def impossible_values(report):
    """The final model's physically impossible values, as text."""
    out = []
    for p in report["final_model"]["parameters"]:
        v, se = p["value"], p.get("std_error")
        se = se if isinstance(se, (int, float)) and se == se else 0.0
        if p["name"] in ("Fv", "sigma0", "sigma1", "Fc", "Fs") and v + 1.96 * se < 0:
            out.append(f"{p['name']} {v:.3g} +- {se:.2g}")
        if p["name"] in ("mu_c", "mu_s") and not 0 < v <= 2:
            out.append(f"{p['name']} {v:.3g}")
    return out


def describes_record(report):
    return report.get("base_model", {}).get("describes_record", True)


# The effects of the vocabulary a contact law of `--base-model choose` puts in the base.
CONTACT_LAW_EFFECTS = {"elasto_plastic": "presliding_hysteresis", "rate_state": "rate_state",
                       "rate_state_contact": "rate_state"}


def named_effects(report):
    """What the report names, in its order: the laws the contact choice put in the base
    (`base_model.contact_choice.chosen`, e.g. `lugre+elasto_plastic` names presliding
    hysteresis) and still in `final_model.effects`, then the accepted effects. A report
    whose model does not describe the record names no effect, so its contact laws are not
    counted either."""
    accepted = [a["name"] for a in report["accepted_effects"]]
    if not describes_record(report):
        return accepted
    chosen = report.get("base_model", {}).get("contact_choice", {}).get("chosen") or ""
    in_final_model = report.get("final_model", {}).get("effects", [])
    laws = [CONTACT_LAW_EFFECTS[p] for p in chosen.split("+") if p in CONTACT_LAW_EFFECTS]
    # A law an accepted effect was fitted without has left the model
    # (`contact_choice.left_model`): it is no longer named.
    laws = [law for law in laws if law in in_final_model]
    return list(dict.fromkeys(laws + accepted))


TRUE_VELOCITY_COLUMN = "v_true_m_per_s"


def gives_true_motion(module):
    run = getattr(module, "run", None)
    return run is not None and "traces" in inspect.signature(run).parameters


def add_true_velocity(module, csv, effect, seed):
    """Rewrite CSV with the generator's true velocity (m/s) at each record sample as a last column."""
    with open(csv) as f:
        lines = f.read().splitlines()
    if lines[0].endswith("," + TRUE_VELOCITY_COLUMN):
        return
    _, rec = module.run(effect, seed, traces=True)
    velocity = rec["v_true"]
    if len(velocity) != len(lines) - 1:
        raise RuntimeError(f"{csv}: {len(lines) - 1} samples but {len(velocity)} true velocities")
    with open(csv, "w") as f:
        f.write(lines[0] + "," + TRUE_VELOCITY_COLUMN + "\n")
        for line, v in zip(lines[1:], velocity):
            f.write(f"{line},{v:.9e}\n")


def diagnose(tribo_fit, csv, extra, reuse):
    path = csv[:-4] + ".report.json"
    if reuse and os.path.exists(path):
        with open(path) as f:
            return json.load(f), "", None
    started = time.perf_counter()
    r = subprocess.run(["nice", tribo_fit, "diagnose", csv] + CONTRACT + extra, capture_output=True, text=True)
    wall = time.perf_counter() - started
    if r.returncode != 0:
        return None, r.stderr, wall
    with open(path, "w") as f:
        f.write(r.stdout)
    return json.loads(r.stdout), "", wall


def score_file(family, module, base_effects, tribo_fit, out_dir, effect, seed, extra, reuse, true_velocity=False):
    family_dir = os.path.join(out_dir, family)
    stem = None
    if reuse:
        stem = next((os.path.join(family_dir, f[:-len(".report.json")]) for f in sorted(os.listdir(family_dir))
                     if f.endswith(f"{effect}_seed{seed}.report.json")), None) if os.path.isdir(family_dir) else None
    csv = stem + ".csv" if stem else module.write(family_dir, effect, seed)
    if true_velocity:
        add_true_velocity(module, csv, effect, seed)
        extra = extra + ["--velocity", TRUE_VELOCITY_COLUMN]
    with open(csv[:-4] + ".json") as f:
        truth = json.load(f)
    report, error, wall = diagnose(tribo_fit, csv, extra, reuse and stem is not None)
    row = {"family": family, "effect": effect, "seed": seed, "in_vocabulary": in_vocabulary(effect, truth),
           "wall_s": wall}
    if report is None:
        row.update(status="failed", error=error.strip()[:300])
        return row
    named = [name for name in named_effects(report) if name not in base_effects]
    first = named[0] if named else None
    describes = describes_record(report)
    row.update(status="ok", named=named, first=first, describes_record=describes,
               unexplained=report.get("unexplained") is not None,
               heldout_nrmse=[report["error_before"]["heldout"]["nrmse"], report["error_after"]["heldout"]["nrmse"]],
               elapsed_s=report.get("elapsed_s"))
    row["false_first"] = first is not None and first != effect
    if effect == "none":
        row["kind"] = "clean"
        row["right"] = first is None
        if truth.get("base_form_matches", True):
            row["coverage"] = coverage(report, truth)
    elif row["in_vocabulary"]:
        row["kind"] = "effect"
        row["right"] = first == effect
        injected = analysis_strength(effect, truth)
        mds = minimum_detectable(report, effect)
        row["below_detection"] = is_below_detection(row["right"], injected, mds)
        row["injected_analysis_strength"], row["minimum_detectable"] = injected, mds
    else:
        row["kind"] = "oov"
        row["right"] = first is None and row["unexplained"]
    row["impossible"] = impossible_values(report) if describes else []
    return row


def summarise(rows):
    ok = [r for r in rows if r["status"] == "ok"]
    clean = [r for r in ok if r["kind"] == "clean"]
    effects = [r for r in ok if r["kind"] == "effect"]
    identifiable = [r for r in effects if not r["below_detection"]]
    oov = [r for r in ok if r["kind"] == "oov"]
    cov = [c for r in clean for _, c in r.get("coverage", [])]
    by_effect = {}
    for r in effects:
        e = by_effect.setdefault(r["effect"], {"right": 0, "identifiable": 0, "below_detection": 0, "files": 0})
        e["files"] += 1
        e["right"] += r["right"]
        e["identifiable"] += not r["below_detection"]
        e["below_detection"] += r["below_detection"]
    walls = [r["wall_s"] for r in ok if r.get("wall_s") is not None]
    return {
        "files": len(rows), "failed": len(rows) - len(ok),
        "clean_accept_nothing": [sum(r["right"] for r in clean), len(clean)],
        "named_first_identifiable": [sum(r["right"] for r in identifiable), len(identifiable)],
        "below_detection": sum(r["below_detection"] for r in effects),
        "by_effect": by_effect,
        "false_first": [sum(r["false_first"] for r in ok), len(ok)],
        "oov_unexplained": [sum(r["right"] for r in oov), len(oov)],
        "coverage_95": [sum(cov), len(cov)],
        "coverage_by_parameter": _coverage_by_parameter(clean),
        "impossible_files": [sum(bool(r["impossible"]) for r in ok), len(ok)],
        "base_not_describing": sum(not r.get("describes_record", True) for r in ok),
        "median_wall_s": statistics.median(walls) if walls else None,
    }


def _coverage_by_parameter(clean):
    out = {}
    for r in clean:
        for name, c in r.get("coverage", []):
            out.setdefault(name, [0, 0])
            out[name][0] += c
            out[name][1] += 1
    return out


def _frac(pair):
    k, n = pair
    return f"{k}/{n}" + (f" ({100 * k / n:.0f} %)" if n else "")


def table(split, summaries):
    lines = [f"| {split} family | clean: nothing named | effects named first (identifiable) | below detection "
             "| false first (all files) | out-of-vocabulary unexplained | base 95 % coverage (clean) "
             "| impossible values | base said not to describe | failed | median wall s |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for family, s in summaries.items():
        wall = f"{s['median_wall_s']:.1f}" if s["median_wall_s"] is not None else "-"
        lines.append(f"| {family} | {_frac(s['clean_accept_nothing'])} | {_frac(s['named_first_identifiable'])} "
                     f"| {s['below_detection']} | {_frac(s['false_first'])} | {_frac(s['oov_unexplained'])} "
                     f"| {_frac(s['coverage_95'])} | {_frac(s['impossible_files'])} | {s['base_not_describing']} "
                     f"| {s['failed']} | {wall} |")
    lines.append("")
    lines.append(f"| {split}: named first by effect | " + " | ".join(summaries) + " |")
    lines.append("|---|" + "---|" * len(summaries))
    effects = sorted({e for s in summaries.values() for e in s["by_effect"]})
    for e in effects:
        cells = []
        for s in summaries.values():
            b = s["by_effect"].get(e)
            cells.append("-" if b is None else f"{b['right']}/{b['identifiable']}"
                         + (f" (+{b['below_detection']} below detection)" if b["below_detection"] else ""))
        lines.append(f"| {e} | " + " | ".join(cells) + " |")
    lines.append("")
    lines.append(f"| {split}: base 95 % coverage by parameter | " + " | ".join(summaries) + " |")
    lines.append("|---|" + "---|" * len(summaries))
    names = sorted({n for s in summaries.values() for n in s["coverage_by_parameter"]})
    for n in names:
        lines.append(f"| {n} | " + " | ".join(_frac(s["coverage_by_parameter"][n]) if n in s["coverage_by_parameter"]
                                              else "-" for s in summaries.values()) + " |")
    return "\n".join(lines) + "\n"


def file_line(r):
    if r["status"] != "ok":
        return f"{r['family']:16s} {r['effect']:24s} seed {r['seed']:3d}: FAILED {r['error'][:200]}"
    extra = ""
    if r.get("coverage"):
        extra += " coverage " + " ".join(f"{n}:{'ok' if c else 'MISS'}" for n, c in r["coverage"])
    if r.get("below_detection"):
        extra += f" (below detection: {r['injected_analysis_strength']:.3g} < {r['minimum_detectable']:.3g})"
    if r["impossible"]:
        extra += " IMPOSSIBLE " + "; ".join(r["impossible"])
    if not r.get("describes_record", True):
        extra += " [base said not to describe the record]"
    return (f"{r['family']:16s} {r['effect']:24s} seed {r['seed']:3d}: {'RIGHT' if r['right'] else 'wrong'} "
            f"named {r['named']} held-out NRMSE {r['heldout_nrmse'][0]:.3f}->{r['heldout_nrmse'][1]:.3f} "
            f"wall {r['wall_s'] or 0:.1f} s{extra}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("tribo_fit")
    ap.add_argument("out_dir")
    ap.add_argument("--split", required=True, choices=sorted(SPLIT_NAMES))
    ap.add_argument("--splits", default=os.path.join(ROOT, "tests", "validation", "splits.toml"))
    ap.add_argument("--families", help="comma-separated; default every family of the split")
    ap.add_argument("--effects", help="comma-separated; default every effect of each family")
    ap.add_argument("--seeds", help="comma-separated; default the split's seeds of each family")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--extra", default="", help="extra tribo-fit arguments")
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--true-velocity", action="store_true",
                    help="give the generator's true velocity as --velocity (an oracle, not the contract command)")
    args = ap.parse_args()
    split = SPLIT_NAMES[args.split]
    with open(args.splits, "rb") as f:
        families = tomllib.load(f)[split]
    if args.families:
        families = {k: v for k, v in families.items() if k in args.families.split(",")}
    tribo_fit = os.path.abspath(args.tribo_fit)
    jobs = []
    with cf.ThreadPoolExecutor(args.jobs) as pool:
        for family, spec in families.items():
            module = load_module(spec["module"])
            if module is None:
                print(f"{family}: {spec['module']} is not in this tree; not scored")
                continue
            if args.true_velocity and not gives_true_motion(module):
                sys.exit(f"{family}: its generator gives no true motion (run(..., traces=True)); --true-velocity "
                         "is for families that do")
            effects = args.effects.split(",") if args.effects else [
                e for e in module.EFFECTS if e not in spec.get("effects_excluded", [])]
            effects = [e for e in effects if e in module.EFFECTS]
            seeds = [int(s) for s in args.seeds.split(",")] if args.seeds else spec["seeds"]
            if split == "validation" and not set(seeds) <= set(spec["seeds"]):
                sys.exit(f"{family}: seeds {sorted(set(seeds) - set(spec['seeds']))} are not validation seeds")
            for e in effects:
                for s in seeds:
                    jobs.append(pool.submit(score_file, family, module, spec.get("base_effects", []), tribo_fit,
                                            args.out_dir, e, s, args.extra.split(), args.reuse,
                                            args.true_velocity))
        rows = []
        for job in jobs:
            rows.append(job.result())
            if split == "development":
                print(file_line(rows[-1]), flush=True)
    summaries = {}
    for family in families:
        family_rows = [r for r in rows if r["family"] == family]
        if family_rows:
            summaries[family] = summarise(family_rows)
    text = table(split, summaries)
    print()
    print(text)
    os.makedirs(args.out_dir, exist_ok=True)
    with open(os.path.join(args.out_dir, f"score_{args.split}.md"), "w") as f:
        f.write(text)
    with open(os.path.join(args.out_dir, f"score_{args.split}.json"), "w") as f:
        json.dump({"split": split, "command": sys.argv, "extra": args.extra,
                   "true_velocity": args.true_velocity, "summaries": summaries,
                   "files": rows if split == "development" else []}, f, indent=1)


if __name__ == "__main__":
    main()
