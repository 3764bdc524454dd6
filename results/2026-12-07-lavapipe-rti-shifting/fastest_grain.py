import sys, csv, math
# fastest grain (speed) at the body records nearest each time in ms: fastest_grain.py bodies.csv MS ...
path = sys.argv[1]; want = [float(a) * 1e-3 for a in sys.argv[2:]]
best = {}  # time -> max speed
for r in csv.DictReader(open(path)):
    t = float(r["time_s"])
    v = math.sqrt(sum(float(r[k]) ** 2 for k in ("vx_m_per_s", "vy_m_per_s", "vz_m_per_s")))
    if v > best.get(t, -1.0):
        best[t] = v
ts = sorted(best)
for w in want:
    t = min(ts, key=lambda x: abs(x - w))
    print(f"{w*1e3:.1f} ms (record {t*1e3:.3f}): fastest grain {best[t]*1e3:.2f} mm/s")
