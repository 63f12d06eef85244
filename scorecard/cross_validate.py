#!/usr/bin/python3
"""The cross-validated scorecard: every split of scorecard/splits.json scored
on its fitted config over several seeds, its fit rows beside its predicted
rows, as markdown.

  /usr/bin/python3 scorecard/cross_validate.py [--splits a,b,...] [--seeds 1-5] [--out DIR] [--jobs 2] [--reuse]
                                             [--configs DIR]

--configs DIR scores each split on DIR/NAME.textproto instead of its own
config (the splits without such a file are left out): another contact law's
fits, e.g. config/instruments/slip_rate_contact (scorecard/fit_contact.py
--law slip_rate).

Runs `build/scorecard/tribo-scorecard --split NAME --seed N --json` for each
split and seed (about 13 s of CPU each), keeps the outputs in DIR/NAME/seedN.json
(--reuse: read those instead of rerunning), and prints

  1. per split: goals met on its fit rows and on its predicted rows, for each
     seed, and their mean;
  2. the goal rows side by side: for each split the mean over the seeds, the
     seeds' band [min-max], the error of the mean, whether the mean meets the
     goal (✓/✗), on how many seeds the row met it, and the row's role
     (F fit, P predicted);
  3. the trends and the rows of the protocol the contacts were not fitted on,
     the same way (no goals).
"""
import argparse
import concurrent.futures
import json
import os
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCORECARD = os.path.join(ROOT, "build", "scorecard", "tribo-scorecard")
SPLITS = os.path.join(ROOT, "scorecard", "splits.json")
TRENDS = ("ds_trend", "overshoot_trend", "FsN_trend", "Fs_after_passes", "ts_after_passes", "overshoot",
          "acceleration", "Fs_absolute", "peak", "spike_rise", "drift", "spread")


def seeds_of(text):
    if "-" in text:
        lo, hi = text.split("-")
        return list(range(int(lo), int(hi) + 1))
    return [int(s) for s in text.split(",")]


def run(split, seed, out_dir, reuse, configs=None):
    path = os.path.join(out_dir, split, f"seed{seed}.json")
    if not (reuse and os.path.exists(path)):
        os.makedirs(os.path.dirname(path), exist_ok=True)
        config = ["--config", os.path.join(configs, split + ".textproto")] if configs else []
        result = subprocess.run([SCORECARD, *config, "--split", split, "--seed", str(seed), "--json"],
                                capture_output=True, text=True)
        if result.returncode != 0:
            sys.exit(f"cross_validate.py: tribo-scorecard --split {split} --seed {seed}: {result.stderr.strip()}")
        with open(path, "w", encoding="utf-8") as f:
            f.write(result.stdout)
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def micro(text):
    """The older rows' keys say uN, um; the tables write µ."""
    for a, b in ((" uN", " µN"), (" um", " µm"), ("(um", "(µm"), ("um/s^2", "µm/s²")):
        text = text.replace(a, b)
    return text


def number(v):
    if v is None:
        return "–"
    a = abs(v)
    return f"{v:.0f}" if a >= 100 else (f"{v:.2f}" if a >= 1 else f"{v:.3f}")


def error_text(row, value):
    if row["dissertation"] is None or value is None:
        return "–"
    if row["error_in_points"]:
        return f"{value - row['dissertation']:+.1f} pt"
    return f"{100 * (value - row['dissertation']) / row['dissertation']:+.0f} %"


def within(row, value):
    if row["error_in_points"]:
        return abs(value - row["dissertation"]) <= row["goal"]
    return abs(value - row["dissertation"]) / abs(row["dissertation"]) <= row["goal"]


def cell(rows_over_seeds, with_goal):
    values = [r["simulated"] for r in rows_over_seeds if r["simulated"] is not None]
    r = rows_over_seeds[0]
    if not values:
        return "–"
    mean = statistics.fmean(values)
    text = f"{number(mean)} [{number(min(values))}–{number(max(values))}] {error_text(r, mean)}"
    if with_goal and r["goal"]:
        met = sum(1 for x in rows_over_seeds if x["within_goal"])
        text += f" {'✓' if within(r, mean) else '✗'} {met}/{len(rows_over_seeds)}"
    role = {"fit": "F", "predicted": "P"}.get(r["role"], "")
    return f"{text} {role}".rstrip()


def table(keys, first, by_split, names, with_goal):
    lines = ["| source | observation | unit | dissertation | " + " | ".join(names) + " |",
             "|---|---|---|---|" + "---|" * len(names)]
    for key in keys:
        r = first[key]
        cells = [cell(by_split[n][key], with_goal) if key in by_split[n] else "–" for n in names]
        lines.append(f"| {r['source']} | {micro(r['observation'])} | {micro(r['unit'])} | {number(r['dissertation'])} | "
                     + " | ".join(cells) + " |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--splits", help="comma-separated (default: all of scorecard/splits.json)")
    ap.add_argument("--seeds", default="1-5")
    ap.add_argument("--out", default=os.path.join(ROOT, "build", "cross_validation"))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--reuse", action="store_true", help="read DIR/NAME/seedN.json where present")
    ap.add_argument("--configs", help="score split NAME on CONFIGS/NAME.textproto (splits without one left out)")
    args = ap.parse_args()
    declared = json.load(open(SPLITS, encoding="utf-8"))["splits"]
    names = args.splits.split(",") if args.splits else [s["name"] for s in declared]
    if args.configs:
        names = [n for n in names if os.path.exists(os.path.join(args.configs, n + ".textproto"))]
    seeds = seeds_of(args.seeds)
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        futures = {(n, s): pool.submit(run, n, s, args.out, args.reuse, args.configs) for n in names for s in seeds}
        results = {k: f.result() for k, f in futures.items()}

    # 1. goals met per split and seed
    print("| split | fitted on | goals met on fit rows, seeds " + ", ".join(map(str, seeds)) + " (mean) | "
          "goals met on predicted rows, seeds " + ", ".join(map(str, seeds)) + " (mean) |")
    print("|---|---|---|---|")
    about = {s["name"]: s for s in declared}
    for n in names:
        fit = [results[(n, s)]["goals_met"]["fit"] for s in seeds]
        pred = [results[(n, s)]["goals_met"]["predicted"] for s in seeds]
        selectors = "; ".join(", ".join(f"{k} {v}" for k, v in sel.items()) for sel in about[n]["fit_rows"])

        def counts(c):
            return ", ".join(str(x["met"]) for x in c) + f" of {c[0]['of']} ({statistics.fmean(x['met'] for x in c):.1f})"
        print(f"| {n} | {selectors} | {counts(fit)} | {counts(pred)} |")
    print()

    # 2. and 3. the rows, side by side
    by_split, first, order = {}, {}, []
    for n in names:
        by_split[n] = {}
        for s in seeds:
            for r in results[(n, s)]["rows"]:
                key = (r["source"], r["observation"])
                if key not in first:
                    first[key] = r
                    order.append(key)
                by_split[n].setdefault(key, []).append(r)
    print(f"Goal rows: mean over seeds {args.seeds} [min–max], error of the mean, ✓/✗ the mean within the goal, "
          "seeds within the goal, F fit / P predicted.\n")
    print(table([k for k in order if first[k]["goal"]], first, by_split, names, True))
    print("\nTrends, the unseen protocol and other rows without a goal (mean [min–max], error of the mean, role):\n")
    print(table([k for k in order if not first[k]["goal"] and first[k]["quantity"] in TRENDS], first, by_split,
                names, False))


if __name__ == "__main__":
    main()
