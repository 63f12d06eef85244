#!/usr/bin/python3
"""The motion estimate's velocity error on a loop soft against the contact:
servo_ipd's development clean records (seeds 1-5; tests/validation/splits.toml),
each diagnosed by tribo-fit with the contract command's columns, --out DIR, and
each --motion-estimator named; the velocity the diagnosis used (traces.csv)
against the generator's true velocity at the samples averaged over 5 samples
(the loop's dither, which no record rate resolves, left out), RMS in um/s:

  onsets  within 0.2 s of a point where the setpoint starts or stops moving;
  steady  while the setpoint moves, farther than 0.2 s from any change of its slope.

Figures: docs/identification.md, "The motion estimate". Not part of the test
suite (about a minute of CPU).

usage: motion_estimate_errors.py TRIBO_FIT WORK_DIR [--estimators rts,rts_stretches] [--seeds 1,2,3,4,5]
"""
import argparse
import importlib.util
import os
import subprocess

import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
GENERATOR = os.path.join(ROOT, "tests", "validation", "families", "servo_ipd", "generate.py")
DEVELOPMENT_SEEDS = (1, 2, 3, 4, 5)


def load_generator():
    spec = importlib.util.spec_from_file_location("servo_ipd_generate", GENERATOR)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def regions(t, r, window_s=0.2):
    """Masks of the onsets and of steady motion, from the setpoint alone."""
    slope = np.diff(r) / np.median(np.diff(t))
    steepest = np.max(np.abs(slope))
    moving = np.abs(slope) > 1e-3 * steepest
    changes = np.nonzero(np.abs(np.diff(slope)) > 0.02 * np.maximum(np.abs(slope[1:]), np.abs(slope[:-1]))
                         + 1e-3 * steepest)[0] + 1
    w = int(round(window_s / np.median(np.diff(t))))
    onset = np.zeros(len(t), bool)
    near = np.zeros(len(t), bool)
    for i in changes:
        near[max(0, i - w):i + w + 1] = True
        if moving[i - 1] != moving[min(i, len(moving) - 1)]:
            onset[max(0, i - w):i + w + 1] = True
    steady = np.append(moving, moving[-1]) & ~near
    return onset, steady


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("tribo_fit")
    ap.add_argument("work_dir")
    ap.add_argument("--estimators", default="rts,rts_stretches")
    ap.add_argument("--seeds", default=",".join(map(str, DEVELOPMENT_SEEDS)))
    args = ap.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    if any(s not in DEVELOPMENT_SEEDS for s in seeds):
        raise SystemExit("only servo_ipd's development seeds (1-5): the others are frozen validation data")
    gen = load_generator()
    os.makedirs(args.work_dir, exist_ok=True)
    print("estimator seed rate_hz onsets_um_s steady_um_s")
    for seed in seeds:
        csv = gen.write(args.work_dir, "none", seed)
        _, rec = gen.run("none", seed, traces=True)
        v5 = np.convolve(rec["v_true"], np.ones(5) / 5, mode="same")
        t, reference = np.loadtxt(csv, delimiter=",", skiprows=1, usecols=(0, 2), unpack=True)
        onset, steady = regions(t, reference)
        rate_hz = 1.0 / np.median(np.diff(t))
        for est in args.estimators.split(","):
            out = os.path.join(args.work_dir, f"seed{seed}_{est}")
            subprocess.run([args.tribo_fit, "diagnose", csv, "--time", "t_s", "--position", "x_m", "--force", "force_N",
                            "--normal", "normal_N", "--reference", "x_ref_m", "--motion-estimator", est,
                            "--effects", "tilt_offset", "--out", out], check=True, stdout=subprocess.DEVNULL)
            v = np.loadtxt(os.path.join(out, "traces.csv"), delimiter=",", skiprows=1, usecols=2)
            rms = lambda m: float(np.sqrt(np.mean((v[m] - v5[m]) ** 2))) * 1e6
            print(f"{est} {seed} {rate_hz:.0f} {rms(onset):.2f} {rms(steady):.2f}")


if __name__ == "__main__":
    main()
