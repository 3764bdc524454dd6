"""Vertical speed of the RTI block's grains, layer by layer of the starting lattice, at
a few record times: `python3 grain_layers.py RUN/bodies.csv [Y0 DR]` (the lattice's
lowest centre row and spacing, m; default the RTI scenes' 3.0e-3 and 1.378234e-4).
Layer means alternating along the block, with a spread across each layer smaller than
their swing, are a wave through the block that is uniform across it."""
import csv
import sys

import numpy as np

path = sys.argv[1]
y0 = float(sys.argv[2]) if len(sys.argv) > 2 else 3.0e-3
dr = float(sys.argv[3]) if len(sys.argv) > 3 else 1.378234e-4
rows = list(csv.reader(open(path)))[1:]
t = np.array([float(r[0]) for r in rows])
y = np.array([float(r[4]) for r in rows])
vy = np.array([float(r[11]) for r in rows])
times = np.unique(t)
for T in [times[len(times) // 4], times[int(len(times) * 0.6)], times[int(len(times) * 0.85)], times[-1]]:
    m = t == T
    layer = np.round((y[m] - y0) / dr).astype(int)
    print(f"t = {T:.4f} s: grains' vy mean {vy[m].mean():+.3e}, min {vy[m].min():+.3e}, max {vy[m].max():+.3e} m/s")
    for k in sorted(set(layer)):
        s = layer == k
        print(f"  layer {k:2d} y {y[m][s].mean():.4e} m, {s.sum():3d} grains, vy {vy[m][s].mean():+.3e} ± {vy[m][s].std():.2e} m/s")
