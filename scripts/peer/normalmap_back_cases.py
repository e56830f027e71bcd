# The cases of caustica's unit test `a_map_normal_turned_back_reflects_only_on_its_front`
# (src/scene/material.rs): Mitsuba 3.9.1's normalmap over a white diffuse whose map's normal points below
# the surface (what a bump map gives on a shape whose to_world mirrors), seen from above (c, Mitsuba's
# si.wi) with light l from anywhere. Where c lies behind the normal the nested BSDF is taken about (after
# the map's flip), Mitsuba's one-sided nested BSDF reflects nothing; a nested BSDF that faces the normal
# towards c reflects light from below the surface to above it. The first cases are of that kind.
# Run with .peer-venv/bin/python (scripts/peer/env).
import mitsuba as mi, numpy as np
from normalmap_common import case_line, mapped_diffuse, tilted, unit
rng = np.random.default_rng(11)
want_zero, want_lit = 4, 3
out = []
while want_zero + want_lit > 0:
    tilt = np.radians(rng.uniform(95, 130)); az = rng.uniform(0, 2*np.pi)
    b, si, col = mapped_diffuse(tilted(tilt, az), '/tmp/cnb.exr')
    n0 = unit(np.array(col, dtype=np.float64)*2-1)
    for _ in range(2000):
        c = unit(rng.normal(size=3)); c[2] = abs(c[2]); l = unit(rng.normal(size=3))
        flip = (c @ [0, 0, 1]) * (c @ n0) <= 0
        n1 = unit(np.array([0, 0, 2*n0[2]]) - n0) if flip else n0
        # Where a two-sided nested diffuse would reflect: c and l on one side of n1, l on one side of n1 and ns.
        two_sided_lit = (c @ n1) * (l @ n1) > 0 and (l @ n1) * l[2] > 0
        si.wi = mi.Vector3f(*c)
        got = b.eval(mi.BSDFContext(), si, mi.Vector3f(*l))[0]
        if got == 0 and two_sided_lit and c @ n1 < 0 and want_zero > 0:
            want_zero -= 1
        elif got > 0 and want_lit > 0:
            want_lit -= 1
        else:
            continue
        out.append(case_line(n0, c, l, got))
        break
print('\n'.join(out))
