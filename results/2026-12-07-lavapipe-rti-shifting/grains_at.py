"""The grains of an RTI run at the body records nearest given times, from its bodies.csv.

usage: grains_at.py BODIES.csv VS PERIOD A0 MS [MS ...]
  VS: the block's settling speed (eq. 35, the report's reference), m/s
  PERIOD: the column's width λ, m;  A0: the disturbance at the start (the report's a(0)), m

Prints per time the fastest grain's speed and the lowest grain's depth a below the
settling face, face(t) = (lowest grain's height at the first record + A0) − VS t, as a,
a/a(0) and a/λ. It reproduces the quick report's a/a(0) (6.47 at 60 ms, 9.89 at 75 ms).
"""
import csv
import math
import sys

path, vs, period, a0 = sys.argv[1], *map(float, sys.argv[2:5])
want = [float(a) * 1e-3 for a in sys.argv[5:]]
lowest, fastest = {}, {}  # time -> lowest height, largest speed
for r in csv.DictReader(open(path)):
    t = float(r["time_s"])
    v = math.sqrt(sum(float(r[k]) ** 2 for k in ("vx_m_per_s", "vy_m_per_s", "vz_m_per_s")))
    lowest[t] = min(lowest.get(t, math.inf), float(r["y_m"]))
    fastest[t] = max(fastest.get(t, 0.0), v)
ts = sorted(lowest)
face0 = lowest[ts[0]] + a0
for w in want:
    t = min(ts, key=lambda x: abs(x - w))
    a = face0 - vs * t - lowest[t]
    print(f"{w*1e3:.1f} ms (record {t*1e3:.3f}): fastest grain {fastest[t]*1e3:.2f} mm/s; "
          f"a = {a*1e3:.3f} mm, a/a(0) = {a/a0:.2f}, a/λ = {a/period:.3f}")
