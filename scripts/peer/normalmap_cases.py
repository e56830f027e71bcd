# The cases of caustica's unit test `normal_map_matches_mitsuba` (src/scene/material.rs): Mitsuba 3.9.1's
# normalmap over a white diffuse (in twosided, seen from behind, for the last four) evaluated at random
# normals and directions. Run with .peer-venv/bin/python (scripts/peer/env).
import mitsuba as mi, numpy as np
from normalmap_common import mapped_diffuse, tilted, unit
rng = np.random.default_rng(5)
cases = []
for trial in range(8):
    tilt = np.radians(rng.uniform(10, 60)); az = rng.uniform(0, 2*np.pi)
    n = tilted(tilt, az)
    two = trial >= 4
    b, si, c = mapped_diffuse(n, '/tmp/cnr.exr', two)
    while True:
        wi = unit(rng.normal(size=3)); wo = unit(rng.normal(size=3))
        if two: wi[2] = -abs(wi[2]); wo[2] = -abs(wo[2])
        else: wi[2] = abs(wi[2]); wo[2] = abs(wo[2])
        si.wi = mi.Vector3f(*wi)
        got = b.eval(mi.BSDFContext(), si, mi.Vector3f(*wo))[0]
        if got > 0 or trial % 4 == 3: break
    mapped = np.array(c, dtype=np.float64)*2-1
    print(f"({two}, [{mapped[0]:.7}, {mapped[1]:.7}, {mapped[2]:.7}], [{wi[0]:.7}, {wi[1]:.7}, {wi[2]:.7}], [{wo[0]:.7}, {wo[1]:.7}, {wo[2]:.7}], {got:.7e}),")
