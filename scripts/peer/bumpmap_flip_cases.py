# The cases of caustica's unit test `a_bump_maps_tangent_follows_its_flipped_normal` (src/scene/mod.rs):
# Mitsuba 3.9.1's bumpmap over an anisotropic rough conductor (reflectance 1, Beckmann, alpha_u 0.05,
# alpha_v 0.4) on a surface whose geometric normal is +z, with a tilted shading normal, a slanted dp/du
# and a steep height gradient, seen from c (Mitsuba's si.wi) and lit from l. Where c lies behind the
# bent normal, Mitsuba turns that normal about the shading normal (flip_invalid_normals) and builds the
# tangent from the turned normal: four cases of that kind, three not, in the order they are found.
# Prints (ns, dp_du, dp_dv, g, c, l, value) tuples in world coordinates for the Rust test.
# Run with .peer-venv/bin/python (scripts/peer/env).
import mitsuba as mi, numpy as np
mi.set_variant('scalar_rgb')
rng = np.random.default_rng(7)


def unit(v):
    return v / np.linalg.norm(v)


# A 2 x 2 height image, read bilinearly: its gradient is constant inside the one texel cell the lookup
# point (0.5, 0.5) sits in, so Mitsuba's eval_1_grad there is what the test hands caustica.
mi.Bitmap(np.array([[0.0, 0.9], [0.3, 0.1]], dtype=np.float32).reshape(2, 2, 1)).write('/tmp/bump-flip.exr')
height = {'type': 'bitmap', 'filename': '/tmp/bump-flip.exr', 'raw': True}
nested = {'type': 'roughconductor', 'material': 'none', 'distribution': 'beckmann', 'alpha_u': 0.05, 'alpha_v': 0.4}
bsdf = mi.load_dict({'type': 'bumpmap', 'texture': height, 'scale': 0.6, 'bsdf': nested})
tex = mi.load_dict(height)
want = {True: 4, False: 3}
out = []
while sum(want.values()) > 0:
    ns = unit(np.array([rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), 1.0]))
    dp_du = np.array([rng.uniform(0.5, 2), rng.uniform(-0.5, 0.5), rng.uniform(-0.3, 0.3)])
    dp_dv = np.array([rng.uniform(-0.5, 0.5), rng.uniform(0.5, 2), rng.uniform(-0.3, 0.3)])
    s = unit(dp_du - ns * (ns @ dp_du))
    t = np.cross(ns, s)
    si = mi.SurfaceInteraction3f()
    si.p = [0, 0, 0]; si.n = [0, 0, 1]; si.uv = [0.5, 0.5]
    si.sh_frame = mi.Frame3f(mi.Vector3f(*s), mi.Vector3f(*t), mi.Vector3f(*ns))
    si.dp_du = mi.Vector3f(*dp_du); si.dp_dv = mi.Vector3f(*dp_dv)
    g = np.array(tex.eval_1_grad(si)) * 0.6
    # The bent normal (world), to tell flipped cases from the rest.
    du = dp_du + ns * (g[0] - ns @ dp_du)
    dv = dp_dv + ns * (g[1] - ns @ dp_dv)
    n = unit(np.cross(du, dv))
    n = n if n[2] >= 0 else -n
    for _ in range(4000):
        c = unit(rng.normal(size=3)); l = unit(rng.normal(size=3))
        if c @ ns <= 0.05 or l @ ns <= 0.05 or c[2] <= 0 or l[2] <= 0:
            continue
        flipped = (c @ n) <= 0
        if want[flipped] == 0:
            continue
        local = lambda v: mi.Vector3f(v @ s, v @ t, v @ ns)
        si.wi = local(c)
        got = bsdf.eval(mi.BSDFContext(), si, local(l))[0]
        if got < 0.05:
            continue
        want[flipped] -= 1
        f = lambda v: ", ".join(f"{x:.7}" for x in v)
        out.append(f"([{f(ns)}], [{f(dp_du)}], [{f(dp_dv)}], [{f(g)}], [{f(c)}], [{f(l)}], {got:.7e}), // " + ("c behind the bent normal: flipped" if flipped else "c in front of the bent normal"))
        break
print("\n".join(out))
