#!/usr/bin/python3
"""Merges tribo-scorecard --json outputs into one markdown table:
observation | dissertation | each configuration's value (error).

  /usr/bin/python3 scorecard/compare.py NAME=FILE.json ...

Rows are matched by source and observation; a run without a row (e.g. an
older scorecard's output, for a before/after table) shows "–" there. A row
that carries a role (tribo-scorecard --split) is marked F (fit) or P
(predicted), and the goals met are counted over each role.
"""
import json
import sys


def micro(text):
    """The older rows' keys say uN, um; the table writes µ."""
    for a, b in ((" uN", " µN"), (" um", " µm"), ("(um", "(µm"), ("um/s^2", "µm/s²")):
        text = text.replace(a, b)
    return text if text not in ("uN", "um", "um/s") else "µ" + text[1:]


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
    mark += {"fit": " F", "predicted": " P"}.get(s.get("role"), "")
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
    met = {n: {} for n in names}  # role -> [met, with a goal]
    for key in order:
        r = first[key]
        cells = []
        for n, rows in zip(names, by_run):
            row = rows.get(key)
            text, ok, counted = cell(row)
            role = (row or {}).get("role") or "all"
            count = met[n].setdefault(role, [0, 0])
            count[0] += ok
            count[1] += counted
            cells.append(text)
        print(f"| {r['source']} | {micro(r['observation'])} | {micro(r['unit'])} | {fmt(r['dissertation'])} | "
              + " | ".join(cells) + " |")
    print()

    def counts(roles):
        return ", ".join(f"{role} rows {m}/{t}" if role != "all" else f"{m}/{t}"
                         for role, (m, t) in sorted(roles.items()) if t)
    print("Goals met (✓ of the rows with a goal): " + "; ".join(f"{n} {counts(r)}" for n, r in met.items()))


if __name__ == "__main__":
    main()
