#!/usr/bin/env python3
"""Every fluid particle within 0.6 spacings of the spike's axis x = z = PERIOD/2 between
heights Y0 and Y1, bottom to top: its distance from the axis, height, vertical and
horizontal speed, pressure, density, and its three nearest neighbours' distances (in
spacings). Input: `fluid_layers RUN.mcap --at MS --csv` (orchestrator/examples).

usage: axis_particles.py PERIOD SPACING Y0 Y1 SNAPSHOT.csv
"""
import sys
import numpy as np

L, s, y0, y1 = (float(v) for v in sys.argv[1:5])
f = sys.argv[5]
rows = open(f).read().split("\nx,y,z,p,vx,vy,vz,rho\n")[1].strip().split("\n")
a = np.array([[float(v) for v in r.split(",")] for r in rows])
c = L / 2
r = np.hypot(a[:, 0] - c, a[:, 2] - c)
ax = a[r < 0.6 * s]
ax = ax[np.argsort(ax[:, 1])]
P = a[:, :3]
for p in ax:
    if not y0 <= p[1] <= y1:
        continue
    d = np.sort(np.sqrt(((P - p[:3]) ** 2).sum(1)))[1:4]
    print(f"r {np.hypot(p[0]-c, p[2]-c)/s:.3f} s, y {p[1]*1e3:.4f} mm: u_y {p[5]*1e3:+8.2f} mm/s, |u_xz| {np.hypot(p[4], p[6])*1e3:.3f} mm/s, p {p[3]:7.1f} Pa, rho {p[7]:7.2f}, nearest {d[0]/s:.3f} {d[1]/s:.3f} {d[2]/s:.3f} s")
