"""Issue 33: N = 10^5 equal spheres to 0.64, polypack then spheropack 0.2.0 in one process (seed 2, growth rate 0.02); one JSON line."""
import sys, time, json, numpy as np, polypack as pp, spheropack
from polypack._kernels import edmd
edmd.warmup(); pp.pack(np.ones(64), 0.3, seed=0)
N=100000; seed=2
la0=open('/proc/loadavg').read().split()[0]
c0=time.process_time(); t0=time.perf_counter(); pk=pp.pack(np.ones(N),0.64,seed=seed,growth_rate=0.02,progress=False); w=time.perf_counter()-t0; cpu=time.process_time()-c0
m=pk.meta; print(json.dumps({"pp_wall":w,"pp_cpu":cpu,"pp_coll":m["collisions"],"load":la0,"phi":pk.volume_fraction}),flush=True)
c0=time.process_time(); t0=time.perf_counter(); res=spheropack.pack(n=N,radii=np.ones(N),density=0.64,growth_rate=0.02,seed=seed); w2=time.perf_counter()-t0
print(json.dumps({"N":N,"seed":seed,"target":0.64,"load":la0,"load_end":open('/proc/loadavg').read().split()[0],"pp_wall":w,"pp_cpu":cpu,"pp_coll":m["collisions"],"pp_cps":m["collisions"]/w,
 "sp_wall":w2,"sp_cpu":time.process_time()-c0,"sp_coll":int(res.n_collisions),"sp_cps":int(res.n_collisions)/w2,"wall_ratio":w2/w,"cps_ratio":(m["collisions"]/w)/(int(res.n_collisions)/w2)}),flush=True)
