# Compares two block-velocity.csv files (t, downward velocity): the means over t >= 6 ms
# (the 12 ms runs' judged stretch) and the second's records over the first's, interpolated
# linearly in t.  python3 compare.py A/block-velocity.csv B/block-velocity.csv
# With --stretches V, the means of one file's records over the stretches of the
# w-0.9-narrow table in comparison.md, for each file given, against a reference speed V
# (eq. 35); a stretch a cut run did not reach is left out, one it reached part of is marked:
#   python3 compare.py --stretches 4.9124e-3 w-0.9-narrow/block-velocity.csv [MORE.csv ...]
# With --falls V, the same stretches' speeds from block-height.csv, each the drop in
# height over the time (the velocity's exact mean over the stretch):
#   python3 compare.py --falls 4.9124e-3 HIGH/block-height.csv
# With --periods V P, means over successive whole periods P of the block speed's slow
# oscillation (about 31 ms), which the stretches above cut through:
#   python3 compare.py --periods 4.9124e-3 0.031 w-0.9-narrow/block-velocity.csv [MORE.csv ...]
# With --turns V, each file's turning points (local extrema) as per cent off V.
import csv,sys,bisect
def load(p):
    r=list(csv.reader(open(p)))[1:]
    return [float(a) for a,b in r],[float(b) for a,b in r]
EDGES=[0.006,0.012,0.06,0.12,0.18,0.27,0.361]  # the w-0.9-narrow table's stretches
if sys.argv[1] in ("--stretches","--falls"):
    # --falls reads block-height.csv (t, lowest grain centre above the floor): a stretch's
    # speed is the drop in height between the records nearest its ends over the time
    # between them, the exact mean of the velocity.
    ref=float(sys.argv[2])
    for p in sys.argv[3:]:
        ts,ys=load(p); print(p)
        for a,b in zip(EDGES,EDGES[1:]):
            if sys.argv[1]=="--stretches":
                s=[v for t,v in zip(ts,ys) if a<=t<b]
                if not s: continue  # a run cut before this stretch
                v=sum(s)/len(s); what="mean %.4e (n=%d)"%(v,len(s))
            else:
                near=lambda x: min(range(len(ts)),key=lambda i: abs(ts[i]-x))
                i,j=near(a),near(b)
                if j<=i: continue
                v=(ys[i]-ys[j])/(ts[j]-ts[i])
                what="fall %.4e m/s over %.3f-%.3f s (height %.3f -> %.3f mm)"%(v,ts[i],ts[j],1e3*ys[i],1e3*ys[j])
            cut=" (cut at t = %.3f s)"%ts[-1] if ts[-1]<b-2.5e-3 else ""
            print("t in [%.3f, %.3f): %s, %+.2f %% off %.4e%s"%(a,b,what,100*(v/ref-1),ref,cut))
    sys.exit()
if sys.argv[1]=="--turns":
    # The velocity records' turning points (local maxima and minima), each as its time and
    # its offset from V, for reading an oscillation's period and decay off a run:
    #   python3 compare.py --turns 2.9689e-4 wg-0.8-c10-16ms/block-velocity.csv
    ref=float(sys.argv[2])
    for p in sys.argv[3:]:
        ts,vs=load(p); print(p)
        for i in range(1,len(vs)-1):
            if (vs[i]-vs[i-1])*(vs[i+1]-vs[i])<0:
                print("t = %6.2f ms: %s %+7.1f %% off %.4e"%(1e3*ts[i],"max" if vs[i]>vs[i-1] else "min",100*(vs[i]/ref-1),ref))
    sys.exit()
if sys.argv[1]=="--periods":
    # Means over successive windows of P seconds from t = 0.012 s (P the period of the
    # block speed's slow oscillation, so that each mean holds a whole period of it), by the
    # trapezoidal rule over the velocity records (within 0.01 % of the fall's mean on
    # the runs here), against V: python3 compare.py --periods V P A.csv [B.csv ...];
    # `--periods V P --from T0 A.csv …` starts at T0 s instead (the water–glycerol
    # quicks' tables: the acoustic period, 0.0024, from 0.0012).
    ref=float(sys.argv[2]); P=float(sys.argv[3]); files=sys.argv[4:]; start=0.012
    if files[:1]==["--from"]: start=float(files[1]); files=files[2:]
    for p in files:
        ts,vs=load(p); print(p); a=start
        while a+P<=ts[-1]+1e-9:
            k=[i for i,t in enumerate(ts) if a-1e-9<=t<=a+P+1e-9]
            pts=[(a,vs[k[0]]+(vs[k[0]]-vs[k[0]-1])*(a-ts[k[0]])/(ts[k[0]]-ts[k[0]-1]))]+[(ts[i],vs[i]) for i in k]
            b=a+P; i=k[-1]
            if ts[i]<b and i+1<len(ts): pts.append((b,vs[i]+(vs[i+1]-vs[i])*(b-ts[i])/(ts[i+1]-ts[i])))
            m=sum((t1-t0)*(v0+v1)/2 for (t0,v0),(t1,v1) in zip(pts,pts[1:]))/(pts[-1][0]-pts[0][0])
            print("t in [%.4f, %.4f]: mean %.4e, %+.2f %% off %.4e"%(a,b,m,100*(m/ref-1),ref))
            a=b
    sys.exit()
ta,va=load(sys.argv[1]); tb,vb=load(sys.argv[2])
def interp(t,ts,vs):
    i=bisect.bisect_left(ts,t)
    if i==0: return vs[0]
    if i>=len(ts): return vs[-1]
    f=(t-ts[i-1])/(ts[i]-ts[i-1]); return vs[i-1]+f*(vs[i]-vs[i-1])
def mean(ts,vs,t0):
    s=[v for t,v in zip(ts,vs) if t>=t0]; return sum(s)/len(s),len(s)
ma=mean(ta,va,6e-3); mb=mean(tb,vb,6e-3)
print("mean a %.4e (n=%d)  mean b %.4e (n=%d)  b/a-1 = %+.2f %%"%(ma[0],ma[1],mb[0],mb[1],100*(mb[0]/ma[0]-1)))
d=[(t,100*(interp(t,tb,vb)/v-1)) for t,v in zip(ta,va) if t>=1e-3 and tb[0]<=t<=tb[-1]]
print("pointwise b/a-1 over t>=1ms: min %+.2f %% at %.2e, max %+.2f %% at %.2e"%(min(d,key=lambda x:x[1])[1],min(d,key=lambda x:x[1])[0],max(d,key=lambda x:x[1])[1],max(d,key=lambda x:x[1])[0]))
dd=[x for x in d if x[0]>=6e-3]
print("pointwise over t>=6ms: min %+.2f %%, max %+.2f %%, rms %.2f %%"%(min(x[1] for x in dd),max(x[1] for x in dd),(sum(x[1]**2 for x in dd)/len(dd))**.5))
