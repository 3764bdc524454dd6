import sys, csv
# approximate lowest grain's depth below the settling face from bodies.csv: face(t) = face0 - vs t,
# face0 = the lowest grain's height at the first record plus a(0)
path=sys.argv[1]; vs=float(sys.argv[2]); L=float(sys.argv[3]); want=[float(a)*1e-3 for a in sys.argv[4:]]
recs={}
for r in csv.DictReader(open(path)):
    recs.setdefault(float(r["time_s"]),[]).append(float(r["y_m"]))
ts=sorted(recs); y0=sorted(recs[ts[0]])
a0=9.8035e-5   # the quick's disturbance at the start (its report)
face0=min(y0)+a0
for w in want:
    t=min(ts,key=lambda x: abs(x-w))
    a=face0-vs*t-min(recs[t])
    print(f"{w*1e3:.0f} ms: a = {a*1e3:.3f} mm, a/a0 = {a/a0:.2f}, a/λ = {a/L:.3f}")
