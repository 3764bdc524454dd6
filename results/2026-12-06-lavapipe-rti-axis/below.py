import sys, numpy as np
# largest fluid speed below y = YMAX (away from the lid), where, and its distance from the spike's axis
L=float(sys.argv[1]); s=float(sys.argv[2]); ymax=float(sys.argv[3])
for f in sys.argv[4:]:
    txt=open(f).read()
    t=float([l for l in txt.split("\n") if l.startswith("layers")][0].split("at t ")[1].split()[0])
    a=np.array([[float(v) for v in r.split(",")] for r in txt.split("\nx,y,z,p,vx,vy,vz,rho\n")[1].strip().split("\n")])
    b=a[a[:,1]<ymax]
    sp=np.linalg.norm(b[:,4:7],axis=1); i=np.argmax(sp)
    r=np.hypot((b[i,0]-L/2+L/2)%L-L/2,(b[i,2]-L/2+L/2)%L-L/2)
    print(f"{t*1e3:.1f} ms: largest speed below y {ymax*1e3:.1f} mm {sp[i]*1e3:.2f} mm/s at y {b[i,1]*1e3:.2f} mm, {r/s:.2f} spacings from the axis; fluid over 20 mm/s there: {(sp>0.02).sum()}")
