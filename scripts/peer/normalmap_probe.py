# Checks the model caustica implements for Mitsuba 3.9.1's normalmap (Mapped in src/scene/material.rs)
# against Mitsuba's own eval on 300 random normals and directions; prints the worst difference.
# Run with .peer-venv/bin/python (scripts/peer/env).
import mitsuba as mi, numpy as np
mi.set_variant('scalar_rgb')
rng = np.random.default_rng(1)
def unit(v): return v/np.linalg.norm(v)
worst = 0
for trial in range(300):
    tilt = np.radians(rng.uniform(5, 70)); az = rng.uniform(0, 2*np.pi)
    n = np.array([np.sin(tilt)*np.cos(az), np.sin(tilt)*np.sin(az), np.cos(tilt)])
    c = ((n+1)/2).astype(np.float32)
    mi.Bitmap(np.tile(c,(2,2,1)).astype(np.float32)).write('/tmp/cnr.exr')
    b = mi.load_dict({'type':'normalmap','normalmap':{'type':'bitmap','filename':'/tmp/cnr.exr','raw':True,'filter_type':'nearest'},
       'bsdf':{'type':'diffuse','reflectance':{'type':'rgb','value':[1,1,1]}}})
    si = mi.SurfaceInteraction3f(); si.p=[0,0,0]; si.n=[0,0,1]; si.sh_frame=mi.Frame3f([0,0,1]); si.uv=[0.1,0.1]; si.dp_du=[1,0,0]; si.dp_dv=[0,1,0]
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
