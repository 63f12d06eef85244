#!/usr/bin/python3
"""Scores tribo-fit on the independent generator (transducer_sim.py): the
development family `independent` of tests/validation/score.py, which holds
the scoring (this name is kept for the commands in docs/identification.md).

usage: score_tribo_fit.py TRIBO_FIT OUT_DIR [--effects a,b] [--seeds 1,2,3] [--jobs 2] [--extra "ARGS"] [--reuse]
"""
import os
import sys

if __name__ == "__main__":
    score = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "validation", "score.py")
    args = sys.argv[1:]
    if "--seeds" not in args:
        args += ["--seeds", "3,17,41"]
    os.execv(sys.executable, [sys.executable, score] + args[:2] + ["--split", "dev", "--families", "independent"]
             + args[2:])
