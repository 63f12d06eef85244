#!/usr/bin/python3
"""Writes a daemon config with some fields of config/tribod.textproto replaced.

  make_config.py BASE OUT field=value...   (field: a dotted path such as
  sim.friction.rate_state.direct_coeff or controller.lateral_displacement.kp)

By editing the text, so that the comments stay: each field must already be present in BASE, or its
parent message must be, in which case it is appended there (a missing block is created). Used by
scorecard/fit_contact.py to try parameter sets without editing files by hand.
"""
import re
import sys


def set_field(text, path, value):
    parts = path.split(".")
    # Find the nested block for each parent, then the field inside it.
    start, end = 0, len(text)
    for name in parts[:-1]:
        m = re.compile(r"(^|\s)" + re.escape(name) + r"\s*\{", re.M).search(text, start, end)
        if not m:  # a new block at the end of its parent
            text = text[:end] + f"\n  {name} {{ }}\n" + text[end:]
            m = re.compile(r"(^|\s)" + re.escape(name) + r"\s*\{", re.M).search(text, start, end + len(name) + 10)
        depth, i = 1, m.end()
        while depth:
            c = text[i]
            depth += c == "{"
            depth -= c == "}"
            i += 1
        start, end = m.end(), i - 1
    leaf = parts[-1]
    pat = re.compile(r"(^|[\s{])(" + re.escape(leaf) + r")\s*:\s*[^\s}#]+", re.M)
    m = pat.search(text, start, end)
    if m:
        return text[: m.start(2)] + f"{leaf}: {value}" + text[m.end() :]
    return text[:end] + f" {leaf}: {value} " + text[end:]


def main():
    base, out, *assignments = sys.argv[1:]
    text = open(base).read()
    for a in assignments:
        path, value = a.split("=", 1)
        text = set_field(text, path, value)
    open(out, "w").write(text)


if __name__ == "__main__":
    main()
