# Checks the model caustica implements for Mitsuba 3.9.1's normalmap (Mapped in src/scene/material.rs)
# against Mitsuba's own eval on 300 random normals and directions; prints the worst difference.
# Run with .peer-venv/bin/python (scripts/peer/env).
import mitsuba as mi, numpy as np
from normalmap_common import mapped_diffuse, tilted, unit
rng = np.random.default_rng(1)
worst = 0
for trial in range(300):
    tilt = np.radians(rng.uniform(5, 70)); az = rng.uniform(0, 2*np.pi)
    n = tilted(tilt, az)
    b, si, _ = mapped_diffuse(n, '/tmp/cnr.exr')
    def rnd_up():
        v = rng.normal(size=3); v[2] = abs(v[2]); return unit(v)
    wi = rnd_up(); wo = rnd_up()
    si.wi = mi.Vector3f(*wi)
    got = b.eval(mi.BSDFContext(), si, mi.Vector3f(*wo))[0]*np.pi
    # model: flip n about the surface normal if wi below it; then cos(n', wo) if wi, wo above n'; times Estevez G on wo
    nn = n.copy()
    if np.dot(wi, nn) <= 0: nn = 2*nn[2]*np.array([0,0,1.0]) - nn
    a2 = min(1.0, np.tan(tilt)**2/8)
    t2o = (1-wo[2]**2)/wo[2]**2
    G = 2/(1+np.sqrt(1+a2*t2o))
    want = (max(0, np.dot(nn, wo)) * G) if (np.dot(nn, wi) > 0 and np.dot(nn, wo) > 0) else 0.0
    err = abs(got-want); worst = max(worst, err)
    if err > 1e-3 and trial < 400: print("mismatch", trial, np.degrees(tilt), got, want, np.dot(n,wi), np.dot(nn,wi), np.dot(nn,wo))
print("worst", worst)
