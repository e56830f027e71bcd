# What the normal-map probes share (normalmap_probe.py, normalmap_cases.py, normalmap_back_cases.py,
# normalmap_nested_twosided_cases.py):
# Mitsuba 3.9.1's normalmap of a single normal (a 2 x 2 image, read nearest) over a white diffuse, and a
# surface interaction at the origin facing +z with du along x. Run with .peer-venv/bin/python.
import mitsuba as mi, numpy as np
mi.set_variant('scalar_rgb')


def unit(v):
    return v / np.linalg.norm(v)


def tilted(tilt, az):
    """The unit normal `tilt` radians from +z, turned `az` radians about it."""
    return np.array([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)])


def mapped_diffuse(n, path, two_sided=False, nested_two_sided=False):
    """(bsdf, si, colour): the normalmap storing normal `n` as the colour (n + 1)/2 in float32 (written
    to `path`), inside a `twosided` if asked (or over a `twosided` diffuse, `nested_two_sided`), and the
    surface interaction to evaluate it at."""
    col = ((n + 1) / 2).astype(np.float32)
    mi.Bitmap(np.tile(col, (2, 2, 1)).astype(np.float32)).write(path)
    inner = {'type': 'normalmap',
             'normalmap': {'type': 'bitmap', 'filename': path, 'raw': True, 'filter_type': 'nearest'},
             'bsdf': {'type': 'diffuse', 'reflectance': {'type': 'rgb', 'value': [1, 1, 1]}}}
    if nested_two_sided:
        inner['bsdf'] = {'type': 'twosided', 'bsdf': inner['bsdf']}
    b = mi.load_dict({'type': 'twosided', 'bsdf': inner} if two_sided else inner)
    si = mi.SurfaceInteraction3f()
    si.p = [0, 0, 0]; si.n = [0, 0, 1]; si.sh_frame = mi.Frame3f([0, 0, 1]); si.uv = [0.1, 0.1]
    si.dp_du = [1, 0, 0]; si.dp_dv = [0, 1, 0]
    return b, si, col


def case_line(n0, c, l, got):
    """One case as the Rust tests write it: (normal, c, l, Mitsuba's value)."""
    return (f"([{n0[0]:.7}, {n0[1]:.7}, {n0[2]:.7}], [{c[0]:.7}, {c[1]:.7}, {c[2]:.7}], "
            f"[{l[0]:.7}, {l[1]:.7}, {l[2]:.7}], {got:.7e}),")
