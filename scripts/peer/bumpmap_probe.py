# Mitsuba 3.9.1's bitmap eval_1_grad (what its bumpmap reads) against finite differences of its own
# eval_1, with and without a to_uv transform (README, "Not done": why bumpmap is not read).
# Run with .peer-venv/bin/python (scripts/peer/env).
import mitsuba as mi, numpy as np
mi.set_variant('scalar_rgb')
rng=np.random.default_rng(2)
img=rng.uniform(0,1,(5,7,3)).astype(np.float32)
mi.Bitmap(img).write('/tmp/h.exr')
for name,tf in [('none',mi.ScalarTransform4f()),('scale',mi.ScalarTransform4f().scale([2,3,1])),('rot',mi.ScalarTransform4f().rotate([0,0,1],30))]:
    t=mi.load_dict({'type':'bitmap','filename':'/tmp/h.exr','raw':True,'to_uv':tf})
    def e(u,v):
        si=mi.SurfaceInteraction3f(); si.uv=[u,v]; return t.eval_1(si)
    si=mi.SurfaceInteraction3f(); si.uv=[0.3,0.7]
    h=1e-4
    print(name, t.eval_1_grad(si), 'fd', (e(0.3+h,0.7)-e(0.3-h,0.7))/(2*h), (e(0.3,0.7+h)-e(0.3,0.7-h))/(2*h))
