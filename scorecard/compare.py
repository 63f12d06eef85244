#!/usr/bin/python3
"""Merges tribo-scorecard --json outputs into one markdown table:
observation | dissertation | each configuration's value (error).

  /usr/bin/python3 scorecard/compare.py NAME=FILE.json ...

Rows are matched by source and observation; a run without a row (e.g. an
older scorecard's output, for a before/after table) shows "–" there.
"""
import json
import sys


def fmt(v):
    if v is None:  # not stated (the dissertation says what happens, not a number)
        return "–"
    a = abs(v)
    return f"{v:.0f}" if a >= 100 else (f"{v:.2f}" if a >= 1 else f"{v:.3f}")


def cell(s):
    if s is None:
        return "–", 0, 0
    if s["error"] is None:
        err = "–"
    else:
        err = f"{s['error']:+.1f} pt" if s["error_in_points"] else f"{100 * s['error']:+.0f} %"
    mark = (" ✓" if s["within_goal"] else " ✗") if s["goal"] else ""
    return f"{fmt(s['simulated'])} ({err}){mark}", int(bool(s["goal"]) and s["within_goal"]), int(bool(s["goal"]))


def main():
    runs = [(a.split("=", 1)[0], json.load(open(a.split("=", 1)[1]))["rows"]) for a in sys.argv[1:]]
    names = [n for n, _ in runs]
    order, first = [], {}
    for _, rows in runs:
        for r in rows:
            key = (r["source"], r["observation"])
            if key not in first:
                first[key] = r
                order.append(key)
    by_run = [{(r["source"], r["observation"]): r for r in rows} for _, rows in runs]
    print("| source | observation | unit | dissertation | " + " | ".join(names) + " |")
    print("|---|---|---|---|" + "---|" * len(names))
    met = {n: [0, 0] for n in names}
    for key in order:
        r = first[key]
        cells = []
        for n, rows in zip(names, by_run):
            text, ok, counted = cell(rows.get(key))
            met[n][0] += ok
            met[n][1] += counted
            cells.append(text)
        print(f"| {r['source']} | {r['observation']} | {r['unit']} | {fmt(r['dissertation'])} | " + " | ".join(cells) + " |")
    print()
    print("Goals met (✓ of the rows with a goal): " + ", ".join(f"{n} {m}/{t}" for n, (m, t) in met.items()))


if __name__ == "__main__":
    main()
