#!/usr/bin/env python3
"""Vertical lines of fluid particles in an RTI column, snapshot by snapshot.

Reads the output of `fluid_layers RUN.mcap --at MS --csv` (every fluid particle of a
snapshot; orchestrator/examples/fluid_layers.rs) and prints, for the particles within
0.3 spacings of each vertical line: how many, the smallest and the largest vertical gap
between consecutive ones (in spacings) and where, and their largest vertical speed.

usage: axis_column.py PERIOD SPACING NAME=X,Z [NAME=X,Z ...] -- SNAPSHOT.csv ...
  X, Z: the line's place in spacings from the domain's corner (the spike's axis of a
  column of odd width W spacings is (W/2, W/2)).
"""
import sys
import numpy as np

L, s = float(sys.argv[1]), float(sys.argv[2])
k = sys.argv.index("--")
lines = []
for a in sys.argv[3:k]:
    name, xz = a.split("=")
    x, z = (float(v) * s for v in xz.split(","))
    lines.append((name, x, z))
print("t (ms),line,particles,min gap (spacings),at y (mm),max gap (spacings),at y (mm),largest |u_y| (mm/s)")
for f in sys.argv[k + 1:]:
    txt = open(f).read()
    t = float([l for l in txt.split("\n") if l.startswith("layers")][0].split("at t ")[1].split()[0])
    rows = txt.split("\nx,y,z,p,vx,vy,vz,rho\n")[1].strip().split("\n")
    a = np.array([[float(v) for v in r.split(",")] for r in rows])
    for name, cx, cz in lines:
        dx = (a[:, 0] - cx + L / 2) % L - L / 2
        dz = (a[:, 2] - cz + L / 2) % L - L / 2
        col = a[np.hypot(dx, dz) < 0.3 * s]
        col = col[np.argsort(col[:, 1])]
        if len(col) < 2:
            print(f"{t*1e3:.1f},{name},{len(col)},,,,,")
            continue
        g = np.diff(col[:, 1])
        i, j = np.argmin(g), np.argmax(g)
        print(f"{t*1e3:.1f},{name},{len(col)},{g[i]/s:.3f},{col[i,1]*1e3:.2f},{g[j]/s:.3f},{col[j,1]*1e3:.2f},{np.abs(col[:,5]).max()*1e3:.1f}")
