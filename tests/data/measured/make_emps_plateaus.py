#!/usr/bin/env python3
"""Steady-state points of the EMPS benchmark record (emps_train_DATA_EMPS.csv, Janot,
Gautier and Brunot 2019): one point per constant-velocity plateau of the reference
x_ref (32 plateaus: +-0.042, +-0.083, +-0.125 m/s), the mean measured velocity and the
mean friction force force_motor - M a over the plateau's second half (the first half
holds the loop's transient after the speed change). M = 95.11 kg, the published
inverse-model mass. Writes emps_plateaus.csv beside this script (tribo-fit stribeck
--diagnose input; docs/identification.md)."""
import os
import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
d = np.genfromtxt(os.path.join(here, 'emps_train_DATA_EMPS.csv'), delimiter=',', names=True)
t, v, a, f = d['t_s'], d['v_derived_m_s'], d['a_derived_m_s2'], d['force_motor_N']
friction = f - 95.11 * a
v_ref = np.round(np.gradient(d['x_ref_m'], t), 3)
edges = np.flatnonzero(np.diff(v_ref) != 0) + 1
rows = []
for seg in np.split(np.arange(len(t)), edges):
    if len(seg) < 300 or abs(v_ref[seg[0]]) < 0.01:
        continue
    half = seg[len(seg) // 2:]
    rows.append((v[half].mean(), friction[half].mean(), t[half[0]], t[half[-1]]))
with open(os.path.join(here, 'emps_plateaus.csv'), 'w') as out:
    out.write('v_m_s,friction_n,t_begin_s,t_end_s\n')
    for r in rows:
        out.write('%.6g,%.6g,%.4f,%.4f\n' % r)
print(len(rows), 'plateaus')
