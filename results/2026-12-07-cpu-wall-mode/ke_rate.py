"""The amplitude's growth rate of a window_trace run: half the slope of ln(KE) against t,
fitted over T0..T1 (s). python3 ke_rate.py FILE T0 T1 [SECTION]: SECTION counts the
"# window_trace" header lines of FILE from 1 (default 1)."""
import math
import re
import sys

path, t0, t1 = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
section = int(sys.argv[4]) if len(sys.argv) > 4 else 1
pts, k = [], 0
for line in open(path):
    if line.startswith("# window_trace"):
        k += 1
    m = re.match(r"t=([0-9.e-]+) KE=([0-9.e+-]+)", line)
    if m and k == section and t0 <= float(m[1]) <= t1:
        pts.append((float(m[1]), math.log(float(m[2]))))
n = len(pts)
mt = sum(t for t, _ in pts) / n
my = sum(y for _, y in pts) / n
slope = sum((t - mt) * (y - my) for t, y in pts) / sum((t - mt) ** 2 for t, _ in pts)
print(f"{n} points over {t0}–{t1} s: ln KE slope {slope:.1f} 1/s, amplitude's rate {slope / 2:.1f} 1/s")
