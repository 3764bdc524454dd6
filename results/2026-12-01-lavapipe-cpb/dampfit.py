# Fits v(t) = c + e^(-k t) (a cos 2πt/T + b sin 2πt/T) to a block-velocity.csv over t >= T0:
# a grid over (k, T), linear least squares for (c, a, b) at each.  python3 dampfit.py CSV T0 VREF
import csv, math, sys
rows=[(float(a),float(b)) for a,b in list(csv.reader(open(sys.argv[1])))[1:]]
t0=float(sys.argv[2]); ref=float(sys.argv[3])
pts=[(t,v) for t,v in rows if t>=t0]
def solve(A,y):
    n=len(A[0]); M=[[sum(r[i]*r[j] for r in A) for j in range(n)] for i in range(n)]
    b=[sum(r[i]*yy for r,yy in zip(A,y)) for i in range(n)]
    for i in range(n):  # Gauss
        p=max(range(i,n),key=lambda r: abs(M[r][i])); M[i],M[p]=M[p],M[i]; b[i],b[p]=b[p],b[i]
        for r in range(i+1,n):
            f=M[r][i]/M[i][i]
            for c in range(i,n): M[r][c]-=f*M[i][c]
            b[r]-=f*b[i]
    x=[0]*n
    for i in reversed(range(n)): x[i]=(b[i]-sum(M[i][c]*x[c] for c in range(i+1,n)))/M[i][i]
    return x
best=None
for k10 in range(0,801,5):
    k=k10/10
    for T10 in range(300,1201,5):
        T=T10/1e4
        A=[[1,math.exp(-k*t)*math.cos(2*math.pi*t/T),math.exp(-k*t)*math.sin(2*math.pi*t/T)] for t,_ in pts]
        y=[v for _,v in pts]; x=solve(A,y)
        ss=sum((yy-sum(a*b for a,b in zip(r,x)))**2 for r,yy in zip(A,y))
        if best is None or ss<best[0]: best=(ss,k,T,x)
ss,k,T,x=best
print("t >= %g s, %d records: plateau %.4e m/s (%+.2f %% off %.4e), decay %.1f 1/s (1/e in %.0f ms), period %.1f ms, amplitude at t0 %.1f %%, rms residual %.2e m/s"%(
    t0,len(pts),x[0],100*(x[0]/ref-1),ref,k,1e3/k if k else float('inf'),1e3*T,100*math.exp(-k*t0)*math.hypot(x[1],x[2])/ref,math.sqrt(ss/len(pts))))
