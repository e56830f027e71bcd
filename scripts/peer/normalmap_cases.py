# The cases of caustica's unit test `normal_map_matches_mitsuba` (src/scene/material.rs): Mitsuba 3.9.1's
# normalmap over a white diffuse (in twosided, seen from behind, for the last four) evaluated at random
# normals and directions. Run with .peer-venv/bin/python (scripts/peer/env).
import mitsuba as mi, numpy as np
mi.set_variant('scalar_rgb')
rng = np.random.default_rng(5)
def unit(v): return v/np.linalg.norm(v)
cases = []
for trial in range(8):
    tilt = np.radians(rng.uniform(10, 60)); az = rng.uniform(0, 2*np.pi)
    n = np.array([np.sin(tilt)*np.cos(az), np.sin(tilt)*np.sin(az), np.cos(tilt)])
    c = ((n+1)/2).astype(np.float32)
    mi.Bitmap(np.tile(c,(2,2,1)).astype(np.float32)).write('/tmp/cnr.exr')
    two = trial >= 4
    inner = {'type':'normalmap','normalmap':{'type':'bitmap','filename':'/tmp/cnr.exr','raw':True,'filter_type':'nearest'},
       'bsdf':{'type':'diffuse','reflectance':{'type':'rgb','value':[1,1,1]}}}
    b = mi.load_dict({'type':'twosided','bsdf':inner} if two else inner)
    si = mi.SurfaceInteraction3f(); si.p=[0,0,0]; si.n=[0,0,1]; si.sh_frame=mi.Frame3f([0,0,1]); si.uv=[0.1,0.1]; si.dp_du=[1,0,0]; si.dp_dv=[0,1,0]
    while True:
        wi = unit(rng.normal(size=3)); wo = unit(rng.normal(size=3))
        if two: wi[2] = -abs(wi[2]); wo[2] = -abs(wo[2])
        else: wi[2] = abs(wi[2]); wo[2] = abs(wo[2])
        si.wi = mi.Vector3f(*wi)
        got = b.eval(mi.BSDFContext(), si, mi.Vector3f(*wo))[0]
        if got > 0 or trial % 4 == 3: break
    mapped = np.array(c, dtype=np.float64)*2-1
    print(f"({two}, [{mapped[0]:.7}, {mapped[1]:.7}, {mapped[2]:.7}], [{wi[0]:.7}, {wi[1]:.7}, {wi[2]:.7}], [{wo[0]:.7}, {wo[1]:.7}, {wo[2]:.7}], {got:.7e}),")
