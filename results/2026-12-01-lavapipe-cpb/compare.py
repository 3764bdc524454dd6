# Compares two block-velocity.csv files (t, downward velocity): the means over t >= 6 ms
# (the 12 ms runs' judged stretch) and the second's records over the first's, interpolated
# linearly in t.  python3 compare.py A/block-velocity.csv B/block-velocity.csv
# With --stretches V, the means of one file's records over the stretches of the
# w-0.9-narrow table in comparison.md, against a reference speed V (eq. 35):
#   python3 compare.py --stretches 4.9124e-3 w-0.9-narrow/block-velocity.csv
import csv,sys,bisect
def load(p):
    r=list(csv.reader(open(p)))[1:]
    return [float(a) for a,b in r],[float(b) for a,b in r]
if sys.argv[1]=="--stretches":
    ref=float(sys.argv[2]); ts,vs=load(sys.argv[3])
    edges=[0.006,0.012,0.06,0.12,0.18,0.27,0.361]
    for a,b in zip(edges,edges[1:]):
        s=[v for t,v in zip(ts,vs) if a<=t<b]
        m=sum(s)/len(s)
        print("t in [%.3f, %.3f): mean %.4e (n=%d), %+.2f %% off %.4e"%(a,b,m,len(s),100*(m/ref-1),ref))
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
