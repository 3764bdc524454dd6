"""Fluid particles below y = YMAX faster than F times the fastest grain, and how far from
the spike's axis (the domain's centre line) they stand.
usage: fast.py PERIOD SPACING YMAX F GRAINS.txt SNAPSHOT.csv ..."""
import re
import sys
import numpy as np

L, s, ymax, f = map(float, sys.argv[1:5])
grain = {}
for line in open(sys.argv[5]):
    m = re.match(r"([0-9.]+) ms .*fastest grain ([0-9.]+) mm/s", line)
    if m:
        grain[round(float(m[1]), 1)] = float(m[2]) * 1e-3
for path in sys.argv[6:]:
    txt = open(path).read()
    t = float([l for l in txt.split("\n") if l.startswith("layers")][0].split("at t ")[1].split()[0])
    a = np.array([[float(v) for v in r.split(",")] for r in txt.split("\nx,y,z,p,vx,vy,vz,rho\n")[1].strip().split("\n")])
    b = a[a[:, 1] < ymax]
    sp = np.linalg.norm(b[:, 4:7], axis=1)
    g = grain[round(t * 1e3 / 5) * 5.0]
    fast = sp > f * g
    r = np.hypot((b[:, 0] % L) - L / 2, (b[:, 2] % L) - L / 2) / s
    rs = np.sort(r[fast])
    print(f"{t*1e3:.1f} ms: fastest grain {g*1e3:.2f} mm/s; {fast.sum()} fluid particles over {f} times it"
          + (f", {rs[0]:.2f}–{rs[-1]:.2f} spacings from the axis (median {np.median(rs):.2f}), the fastest {sp.max()/g:.2f} times it" if fast.any() else ""))
