# Mitsuba 3.9.1's bitmap eval_1_grad (what its bumpmap bends the normal by) against central differences
# of its own eval_1, away from texel centres (where the bilinear interpolant has kinks and central
# differences average two slopes: this probe's first version, at v = 0.7 of a 5-row image, sat on one, which is
# why bumpmap was refused until session 46). Without to_uv and with a scale, on a square image and
# under any to_uv, the two agree; under a turning to_uv on a non-square image they do not (Mitsuba scales
# by the image's size after applying to_uv's transposed matrix): README, "Bump maps".
# Run with .peer-venv/bin/python (scripts/peer/env).
import mitsuba as mi, numpy as np
mi.set_variant('scalar_rgb')
rng = np.random.default_rng(2)
T = mi.ScalarTransform4f
for shape in [(5, 7), (6, 6)]:
    img = rng.uniform(0, 1, shape + (3,)).astype(np.float32)
    mi.Bitmap(img).write('/tmp/h.exr')
    for name, tf in [('none', T()), ('scale', T().scale([2, 3, 1])), ('rotate 30', T().rotate([0, 0, 1], 30))]:
        t = mi.load_dict({'type': 'bitmap', 'filename': '/tmp/h.exr', 'raw': True, 'to_uv': tf})
        def e(u, v):
            si = mi.SurfaceInteraction3f(); si.uv = [u, v]; return t.eval_1(si)
        for (u, v) in [(0.31, 0.73), (0.57, 0.12)]:
            si = mi.SurfaceInteraction3f(); si.uv = [u, v]
            h = 1e-4
            fd = ((e(u + h, v) - e(u - h, v)) / (2 * h), (e(u, v + h) - e(u, v - h)) / (2 * h))
            print(f'{shape[1]}x{shape[0]} {name:9} uv ({u}, {v}): eval_1_grad {t.eval_1_grad(si)}, differences ({fd[0]:.5f}, {fd[1]:.5f})')
