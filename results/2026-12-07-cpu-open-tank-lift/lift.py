# Mean vertical fluid force on body 0 over [T0, T1] s of a recording: lift.py RUN.mcap T0 T1
# (needs the mcap package: pip install mcap).
import sys, json
from mcap.reader import make_reader
path, t0, t1 = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
topics = set()
fy = []
with open(path, 'rb') as f:
    r = make_reader(f)
    for schema, ch, msg in r.iter_messages():
        topics.add(ch.topic)
        if 'load' in ch.topic:
            try:
                v = json.loads(msg.data)
            except Exception:
                continue
            if not isinstance(v, dict): continue
            t = v.get("time"); F = (v.get("loads") or [{}])[0].get("force")
            if t is not None and F and t0 - 1e-9 <= t <= t1 + 1e-9:
                fy.append(F[1])

if fy:
    import statistics
    print(f"n={len(fy)} mean Fy={statistics.mean(fy):.4f} N  min {min(fy):.4f} max {max(fy):.4f}")
