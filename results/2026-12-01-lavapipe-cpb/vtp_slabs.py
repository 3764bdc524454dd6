#!/usr/bin/env python3
"""Horizontal-slab means from couplet's VTK fluid frames (`--set output.vtk=true`).

  vtp_slabs.py profile VTKDIR NSLABS HEIGHT   per frame: t, then per slab (bottom
                                              first) mean pressure / density / u_y
  vtp_slabs.py moved VTKDIR NSLABS HEIGHT     per pair of frames: t, then per slab the
                                              mean displacement rate Δy/Δt / mean u_y

`moved` assumes every frame lists the fluid particles in the same order (couplet's
frames are in id order). HEIGHT: the column's height, m (slabs span 0 to HEIGHT).
"""
import base64, glob, re, struct, sys

def arrays(path):
    text = open(path).read()
    out = {}
    for m in re.finditer(r'<DataArray type="(\w+)"(?: Name="(\w+)")?[^>]*format="binary">([^<]*)</DataArray>', text):
        ty, name, data = m.group(1), m.group(2) or 'Points', m.group(3).strip()
        raw = base64.b64decode(data)
        n = struct.unpack('<Q', raw[:8])[0]
        fmt = {'Float32': 'f', 'Float64': 'd', 'Int64': 'q', 'Int32': 'i', 'UInt8': 'B'}[ty]
        out[name] = struct.unpack('<%d%s' % (n // struct.calcsize(fmt), fmt), raw[8:8 + n])
    return out

def slab(y, ns, height):
    return min(ns - 1, max(0, int(y / height * ns)))

def main():
    mode, vdir, ns, height = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4])
    prev = None
    for f in sorted(glob.glob(vdir + '/fluid_*.vtp')):
        a = arrays(f)
        t, pts, v = a['TimeValue'][0], a['Points'], a['velocity']
        if mode == 'profile':
            acc = [[0.0, 0.0, 0.0, 0] for _ in range(ns)]
            for i in range(len(a['pressure'])):
                s = acc[slab(pts[3 * i + 1], ns, height)]
                s[0] += a['pressure'][i]; s[1] += a['density'][i]; s[2] += v[3 * i + 1]; s[3] += 1
            print('%.5f ' % t + ' '.join('%.2f/%.4f/%+.2e' % (s[0] / max(s[3], 1), s[1] / max(s[3], 1), s[2] / max(s[3], 1)) for s in acc))
        elif prev is not None:
            tp, pp, vp = prev
            acc = [[0.0, 0.0, 0] for _ in range(ns)]
            for i in range(len(pts) // 3):
                s = acc[slab(pts[3 * i + 1], ns, height)]
                s[0] += (pts[3 * i + 1] - pp[3 * i + 1]) / (t - tp); s[1] += 0.5 * (v[3 * i + 1] + vp[3 * i + 1]); s[2] += 1
            print('%.5f ' % t + ' '.join('%+.2e/%+.2e' % (s[0] / max(s[2], 1), s[1] / max(s[2], 1)) for s in acc))
        prev = (t, pts, v)

main()
