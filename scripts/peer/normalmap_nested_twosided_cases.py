# The cases of caustica's unit test `a_normal_map_over_a_two_sided_bsdf_reflects_on_both_sides`
# (src/scene/material.rs): Mitsuba 3.9.1's normalmap over a `twosided` white diffuse (the map outside,
# the twosided inside), seen from below the surface (c, Mitsuba's si.wi, behind the shading normal) with
# light l from anywhere. The nested twosided turns c and l to the front of the normal it is taken about,
# so the surface reflects from below as from above; a one-sided nested BSDF would be black there. The
# first cases are lit ones. Run with .peer-venv/bin/python (scripts/peer/env).
import mitsuba as mi, numpy as np
from normalmap_common import case_line, mapped_diffuse, tilted, unit
rng = np.random.default_rng(5)
want_lit, want_zero = 5, 2
out = []
while want_zero + want_lit > 0:
    tilt = np.radians(rng.uniform(0, 50)); az = rng.uniform(0, 2*np.pi)
    b, si, col = mapped_diffuse(tilted(tilt, az), '/tmp/cnt.exr', nested_two_sided=True)
    n0 = unit(np.array(col, dtype=np.float64)*2-1)
    for _ in range(2000):
        c = unit(rng.normal(size=3)); c[2] = -abs(c[2]); l = unit(rng.normal(size=3))
        si.wi = mi.Vector3f(*c)
        got = b.eval(mi.BSDFContext(), si, mi.Vector3f(*l))[0]
        if got > 0 and want_lit > 0:
            want_lit -= 1
        elif got == 0 and want_lit == 0 and want_zero > 0:
            want_zero -= 1
        else:
            continue
        out.append(case_line(n0, c, l, got))
        break
print('\n'.join(out))
