#!/usr/bin/python3
"""Merges tribo-scorecard --json outputs into one markdown table:
observation | dissertation | each configuration's value (error).

  /usr/bin/python3 scorecard/compare.py NAME=FILE.json ...
"""
import json
import sys


def fmt(v):
    a = abs(v)
    return f"{v:.0f}" if a >= 100 else (f"{v:.2f}" if a >= 1 else f"{v:.3f}")


def main():
    runs = [(a.split("=", 1)[0], json.load(open(a.split("=", 1)[1]))["rows"]) for a in sys.argv[1:]]
    names = [n for n, _ in runs]
    print("| source | observation | unit | dissertation | " + " | ".join(names) + " |")
    print("|---|---|---|---|" + "---|" * len(names))
    met = {n: [0, 0] for n in names}
    for i, r in enumerate(runs[0][1]):
        cells = []
        for n, rows in runs:
            s = rows[i]
            err = f"{s['error']:+.1f} pt" if s["error_in_points"] else f"{100 * s['error']:+.0f} %"
            mark = (" ✓" if s["within_goal"] else " ✗") if s["goal"] else ""
            if s["goal"]:
                met[n][0] += s["within_goal"]
                met[n][1] += 1
            cells.append(f"{fmt(s['simulated'])} ({err}){mark}")
        print(f"| {r['source']} | {r['observation']} | {r['unit']} | {fmt(r['dissertation'])} | " + " | ".join(cells) + " |")
    print()
    print("Goals met (✓ of the rows with a goal): " + ", ".join(f"{n} {m}/{t}" for n, (m, t) in met.items()))


if __name__ == "__main__":
    main()
