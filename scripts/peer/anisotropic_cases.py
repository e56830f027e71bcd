# The cases of caustica's unit test `anisotropic_microfacets_match_mitsuba` (src/scene/material.rs):
# Mitsuba 3.9.1's roughconductor and roughdielectric with alpha_u ≠ alpha_v, evaluated at random
# directions in the shading frame s = x, n = z. Run with .peer-venv/bin/python (scripts/peer/env).
import mitsuba as mi, numpy as np
mi.set_variant('scalar_rgb')
rng = np.random.default_rng(11)
def unit(v): return v/np.linalg.norm(v)
for dist in ['ggx','beckmann']:
  for kind in ['roughconductor','roughdielectric']:
    for trial in range(3):
        au, av = rng.uniform(0.05, 0.6), rng.uniform(0.05, 0.6)
        d = {'type':kind,'distribution':dist,'alpha_u':au,'alpha_v':av}
        if kind=='roughconductor': d['material']='none'
        else: d['int_ior']=1.5; d['ext_ior']=1.0
        b = mi.load_dict(d)
        si = mi.SurfaceInteraction3f(); si.p=[0,0,0]; si.n=[0,0,1]; si.sh_frame=mi.Frame3f([1,0,0],[0,1,0],[0,0,1])
        while True:
            wi = unit(rng.normal(size=3)); wo = unit(rng.normal(size=3))
            wi[2] = abs(wi[2])
            if kind=='roughconductor' or trial==0: wo[2]=abs(wo[2])
            else: wo[2] = -abs(wo[2])
            si.wi = mi.Vector3f(*wi)
            got = b.eval(mi.BSDFContext(), si, mi.Vector3f(*wo))[0]
            if got > 0.05: break
        print(f'("{dist}", "{kind}", {au:.7}, {av:.7}, [{wi[0]:.7}, {wi[1]:.7}, {wi[2]:.7}], [{wo[0]:.7}, {wo[1]:.7}, {wo[2]:.7}], {got:.7e}),')
