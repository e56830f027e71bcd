# The cases of caustica's unit test `principled_anisotropic_matches_mitsuba` (src/scene/material.rs):
# Mitsuba 3.9.1's principled BSDF with `anisotropic` > 0 evaluated at random directions in the shading
# frame s = x, n = z (reflection, and transmission where spec_trans > 0). Run with .peer-venv/bin/python
# (scripts/peer/env).
import mitsuba as mi, numpy as np
mi.set_variant('scalar_rgb')
rng = np.random.default_rng(23)
def unit(v): return v/np.linalg.norm(v)
# (anisotropic, roughness, metallic, spec_trans, eta)
params = [(0.8, 0.4, 1.0, 0.0, 1.5), (0.5, 0.3, 0.3, 0.0, 1.5), (0.9, 0.5, 0.0, 0.8, 1.4), (0.3, 0.25, 0.0, 0.0, 1.5)]
for (an, r, met, st, eta) in params:
    b = mi.load_dict({'type':'principled','base_color':{'type':'rgb','value':[0.8,0.5,0.3]},'anisotropic':an,
                      'roughness':r,'metallic':met,'spec_trans':st,'eta':eta})
    si = mi.SurfaceInteraction3f(); si.p=[0,0,0]; si.n=[0,0,1]; si.sh_frame=mi.Frame3f([1,0,0],[0,1,0],[0,0,1])
    for trial in range(3):
        while True:
            wi = unit(rng.normal(size=3)); wo = unit(rng.normal(size=3))
            wi[2] = abs(wi[2])
            wo[2] = -abs(wo[2]) if (st > 0 and trial == 2) else abs(wo[2])
            si.wi = mi.Vector3f(*wi)
            got = b.eval(mi.BSDFContext(), si, mi.Vector3f(*wo))
            if got[0] > 0.02: break
        print(f'({an}, {r}, {met}, {st}, {eta}, [{wi[0]:.7}, {wi[1]:.7}, {wi[2]:.7}], [{wo[0]:.7}, {wo[1]:.7}, {wo[2]:.7}], [{got[0]:.7e}, {got[1]:.7e}, {got[2]:.7e}]),')
