"""A random Mitsuba 3 XML scene made of what caustica's import reads, for scripts/random-check (caustica's
path tracer against Mitsuba's on scenes nobody chose).

    python3 scripts/peer/random_scene.py SEED OUT.xml [--no-blend] [--area-lights] [--more] [--fog] [--exporter] [--scale S]

The same SEED gives the same scene. A floor (and half the time a back wall) under one to four objects
(sphere, cube, cylinder, disk, rectangle, the PLY ball, the OBJ tile) with random transforms, each of a
random BSDF (diffuse with a colour or a checkerboard, plastic, roughplastic, conductor and
roughconductor by named metal or eta/k, dielectric, thindielectric, roughdielectric, principled with a
random subset of its weights, and blendbsdf, mask and twosided around those), lit by one or two of
area rectangle, area sphere, point, spot, directional, constant and envmap (at most one of the last
two). Random max_depth (2 to unlimited), hide_emitters, box, tent or Gaussian filter; 64 x 48 pixels.
The files it names (ball.ply, colored-ball.ply, facets.ply, inverted-ball.ply, mixed-ball.ply, tile.obj, tile.mtl, label.png, sky.exr, height.png) are tests/mitsuba's; the
caller copies them beside OUT. --no-blend leaves out blendbsdf, mask and twosided (Mitsuba 3.9.1's
own blends are biased where caustica's are not: see the README). --area-lights draws the lights from
area rectangle, area sphere, constant and envmap only: no point, spot or distant light, whose light
through mirrors and glass a path tracer cannot find, so that every mode can be held to the path tracer
(`scripts/random-check --modes --area-lights`). --more adds what the plain scenes never hold, drawn from
a second random stream so that the rest of the scene is the one the same SEED gives without it: an area
emitter on a cube, disk, cylinder (round: Mitsuba samples no other), the PLY ball or the OBJ tile
(non-uniform scale, turned), an object
whose BSDF reads the bitmap label.png (a diffuse or plastic colour, a principled base colour, a rough
conductor's alpha as raw data), a named interior IOR, a thin-lens camera, another fov_axis, a
Mitchell, Lanczos or Catmull-Rom filter, and spectra for about a third of the colours (a constant, or
wavelength:value pairs inline or in a .spd file written beside OUT), and a second BSDF, the front, for
half the twosided ones (the one they had is then their back), a texture for the radiance of some
rectangle and sphere emitters (a checkerboard, sky.exr or label.png), a normal map (bumps.exr) over
the BSDF of about a third of the shapes with texture coordinates, and an anisotropic roughness
(alpha_u and alpha_v) for about three in five rough conductors and dielectrics and an `anisotropic`
for half the principled BSDFs, not on a cylinder; and for half the cylinders a normal map or anisotropy;
an orthographic camera, textured alpha_u/alpha_v, spots projecting a texture; a crop window of a larger
film, and a principal point offset on a pinhole camera; vertex colours on half the PLY balls; a bump
map (height.png or label.png) over about a quarter of the BSDFs of shapes with texture coordinates;
wrap_mode clamp or mirror on a third of the bitmap textures; face colours on half the PLY balls left;
textured principled weights; a textured `anisotropic` for half the anisotropic principled BSDFs;
clipping planes (a near plane that cuts into the scene, a far plane) for about two in five scenes;
a third of the spots turned into projectors; an absorbing interior medium (coloured glass, rendered by
volpath) in four in five closed shapes of smooth or rough glass; a mirroring scale (-1 along one axis)
on a fourth of the rectangles, disks, cubes and meshes without media; flip_normals, a mirroring
scale or both on half the spheres that neither emit nor hold a medium; a ball in diffuse colour, rough
gold or clear glass at the centre of half the spheres, cubes and PLY balls with a medium; three in
five PLY balls left with their vertex normals against their winding; and a fourth of the shapes
that neither emit nor hold a medium placed by an instance of a shapegroup that turns, scales and
sometimes mirrors them.
--exporter writes the same scene as exporters and converters write it (from a stream of its own, each
half the time): `name` labels on nested objects, booleans spelled "True" and "FALSE", references through
<alias>, and a camera mirrored by <scale x="-1"/> (the image mirrored in both renderers).
--scale S writes the same scene scaled by S about the origin (`scale_scene`), whose image is the same.
--fog puts the camera in a fog that scatters (the sensor's medium), under volpath.
"""
import argparse
import os
import random
import re
import xml.etree.ElementTree as ET

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("seed", type=int)
ap.add_argument("out")
ap.add_argument("--no-blend", action="store_true", help="no blendbsdf, mask or twosided")
ap.add_argument("--area-lights", action="store_true", help="no point, spot or directional emitter")
ap.add_argument("--more", action="store_true", help="emitting meshes, bitmap textures, thin lens, more filters")
ap.add_argument("--curves", action="store_true",
                help="one to three linearcurve or bsplinecurve shapes of random strands (not with --scale: "
                     "Mitsuba's to_world scales a curve's points and not its radii)")
ap.add_argument("--scatter", action="store_true",
                help="with --more: the coloured glass's media scatter too (albedo 0.3 to 1 a channel, "
                     "isotropic or Henyey-Greenstein), and every closed glass shape holds one")
ap.add_argument("--fog", action="store_true",
                help="the camera sits in a fog (the sensor's medium: a grey sigma_t of 0.05 to 0.3 a unit, an "
                     "albedo of 0.4 to 1 a channel, isotropic or Henyey-Greenstein), under volpath; not with --scale")
ap.add_argument("--exporter", action="store_true",
                help="the same scene written as other tools write it (labels, True, aliases, a mirrored camera)")
ap.add_argument("--scale", type=float, default=1.0,
                help="the whole scene scaled by this factor about the origin, so that its image stays the same")
args = ap.parse_args()
R = random.Random(args.seed)
# The extras' own stream: the scene without them stays the one the seed gives.
M = random.Random(args.seed * 7919 + 17)
NOBLEND = args.no_blend


def f(x):
    return f"{x:.4g}"


def checkerboard(name, color0, color1, sx, sy=None, kind="rgb"):
    """A checkerboard texture named `name`: its two colours as <kind> values, its to_uv a scale by sx
    (by sx and sy along u and v where sy is given)."""
    scale = f'<scale value="{sx}"/>' if sy is None else f'<scale x="{sx}" y="{sy}"/>'
    return (f'<texture type="checkerboard" name="{name}"><{kind} name="color0" value="{color0}"/>'
            f'<{kind} name="color1" value="{color1}"/><transform name="to_uv">{scale}</transform></texture>')


def bitmap(name, filename):
    """A bitmap texture named `name` reading `filename` (beside the scene)."""
    return f'<texture type="bitmap" name="{name}"><string name="filename" value="{filename}"/></texture>'


def rgb(lo=0.05, hi=0.95):
    return ", ".join(f(R.uniform(lo, hi)) for _ in range(3))


CONDUCTORS = ["Au", "Cu", "Al", "Ag", "Cr", "none"]


def roughness(hi):
    """A microfacet distribution and an alpha up to `hi`."""
    return (f'<string name="distribution" value="{R.choice(["beckmann", "ggx"])}"/>'
            f'<float name="alpha" value="{f(R.uniform(0.05, hi))}"/>')


def bsdf(depth=0, allow_glass=True):
    kinds = ["diffuse", "diffuse_tex", "plastic", "roughplastic", "conductor", "roughconductor",
             "principled", "blend", "mask", "twosided"]
    if allow_glass:
        kinds += ["dielectric", "thindielectric", "roughdielectric"]
    if depth > 0 or NOBLEND:
        kinds = [k for k in kinds if k not in ("blend", "mask", "twosided")]
    k = R.choice(kinds)
    if k == "diffuse":
        return f'<bsdf type="diffuse"><rgb name="reflectance" value="{rgb()}"/></bsdf>'
    if k == "diffuse_tex":
        s = R.choice([2, 4, 7])
        return f'<bsdf type="diffuse">{checkerboard("reflectance", rgb(), rgb(), s, s)}</bsdf>'
    if k == "plastic":
        return (f'<bsdf type="plastic"><rgb name="diffuse_reflectance" value="{rgb(0.05, 0.8)}"/>'
                f'<float name="int_ior" value="{f(R.uniform(1.3, 1.9))}"/>'
                f'<boolean name="nonlinear" value="{R.choice(["true", "false"])}"/></bsdf>')
    if k == "roughplastic":
        return (f'<bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="{rgb(0.05, 0.8)}"/>'
                f'{roughness(0.6)}'
                f'<float name="int_ior" value="{f(R.uniform(1.3, 1.9))}"/>'
                f'<boolean name="nonlinear" value="{R.choice(["true", "false"])}"/></bsdf>')
    if k in ("conductor", "roughconductor"):
        m = R.choice(CONDUCTORS)
        body = f'<string name="material" value="{m}"/>'
        if R.random() < 0.3:
            body = f'<rgb name="eta" value="{rgb(0.1, 2.0)}"/><rgb name="k" value="{rgb(1.0, 5.0)}"/>'
        if R.random() < 0.3:
            body += f'<rgb name="specular_reflectance" value="{rgb(0.4, 1.0)}"/>'
        if k == "roughconductor":
            body += roughness(0.5)
        return f'<bsdf type="{k}">{body}</bsdf>'
    if k in ("dielectric", "thindielectric", "roughdielectric"):
        body = f'<float name="int_ior" value="{f(R.uniform(1.2, 2.0))}"/>'
        if R.random() < 0.3:
            body += f'<rgb name="specular_transmittance" value="{rgb(0.5, 1.0)}"/>'
        if k == "roughdielectric":
            body += roughness(0.5)
        return f'<bsdf type="{k}">{body}</bsdf>'
    if k == "principled":
        body = f'<rgb name="base_color" value="{rgb()}"/>'
        for name in ["roughness", "metallic", "spec_tint", "sheen", "sheen_tint", "flatness", "clearcoat",
                     "clearcoat_gloss"]:
            if R.random() < 0.6:
                body += f'<float name="{name}" value="{f(R.uniform(0.0, 1.0))}"/>'
        if R.random() < 0.5:
            body += f'<float name="specular" value="{f(R.uniform(0.1, 0.9))}"/>'
        if allow_glass and R.random() < 0.3:
            body += f'<float name="spec_trans" value="{f(R.uniform(0.1, 1.0))}"/>'
        return f'<bsdf type="principled">{body}</bsdf>'
    if k == "blend":
        return (f'<bsdf type="blendbsdf"><float name="weight" value="{f(R.uniform(0.1, 0.9))}"/>'
                f'{bsdf(depth + 1, allow_glass)}{bsdf(depth + 1, allow_glass)}</bsdf>')
    if k == "mask":
        return (f'<bsdf type="mask"><float name="opacity" value="{f(R.uniform(0.2, 0.9))}"/>'
                f'{bsdf(depth + 1, allow_glass)}</bsdf>')
    # twosided around an opaque BSDF
    return f'<bsdf type="twosided">{bsdf(depth + 1, False)}</bsdf>'


def transform(s, rx, ry, rz, t):
    return (f'<transform name="to_world"><scale x="{f(s[0])}" y="{f(s[1])}" z="{f(s[2])}"/>'
            f'<rotate x="1" angle="{f(rx)}"/><rotate y="1" angle="{f(ry)}"/><rotate z="1" angle="{f(rz)}"/>'
            f'<translate x="{f(t[0])}" y="{f(t[1])}" z="{f(t[2])}"/></transform>')


def obj():
    kind = R.choice(["sphere", "cube", "cylinder", "disk", "rectangle", "ply", "obj"])
    x, z = R.uniform(-1.3, 1.3), R.uniform(-1.0, 1.0)
    m = bsdf()
    while kind == "cylinder" and "texture" in m:
        m = bsdf()
    if kind == "sphere":
        r = R.uniform(0.2, 0.55)
        return (f'<shape type="sphere"><point name="center" x="{f(x)}" y="{f(r + R.uniform(0.01, 0.4))}" '
                f'z="{f(z)}"/><float name="radius" value="{f(r)}"/>{m}</shape>')
    if kind == "ply":
        r = R.uniform(0.2, 0.5)
        return (f'<shape type="ply"><string name="filename" value="ball.ply"/>'
                f'{transform((r, r, r), 0, R.uniform(0, 90), 0, (x, r + 0.02, z))}{m}</shape>')
    s = [R.uniform(0.15, 0.45) for _ in range(3)]
    rot = (R.uniform(-40, 40), R.uniform(0, 90), R.uniform(-40, 40))
    y = max(s) * 1.8 + 0.02
    if kind == "obj":
        return (f'<shape type="obj"><string name="filename" value="tile.obj"/>'
                f'{transform((s[0] * 2, s[1] * 2, 1), *rot, (x, y, z))}<boolean name="face_normals" value="true"/>{m}</shape>')
    flip = '<boolean name="flip_normals" value="true"/>' if R.random() < 0.2 else ""
    return f'<shape type="{kind}">{transform(s, *rot, (x, y, z))}{flip}{m}</shape>'


def scaled(colour, e):
    """An "r, g, b" colour times e."""
    return ", ".join(f(e * float(v)) for v in colour.split(", "))


def emitter():
    kinds = ["area_rect", "area_sphere", "point", "spot", "directional", "constant", "envmap"]
    if args.area_lights:
        kinds = ["area_rect", "area_sphere", "constant", "envmap"]
    kind = R.choice(kinds)
    c = rgb(0.3, 1.0)
    if kind == "area_rect":
        s = R.uniform(0.2, 0.8)
        e = R.uniform(2, 12)
        return (f'<shape type="rectangle">{transform((s, s, 1), 90 + R.uniform(-30, 30), R.uniform(0, 90), 0, (R.uniform(-1, 1), R.uniform(1.8, 3), R.uniform(-1, 1)))}'
                f'<bsdf type="diffuse"/><emitter type="area"><rgb name="radiance" value="{scaled(c, e)}"/></emitter></shape>')
    if kind == "area_sphere":
        r = R.uniform(0.05, 0.3)
        e = R.uniform(2, 20)
        return (f'<shape type="sphere"><point name="center" x="{f(R.uniform(-1.5, 1.5))}" y="{f(R.uniform(1.5, 3))}" z="{f(R.uniform(-1, 1.5))}"/>'
                f'<float name="radius" value="{f(r)}"/><emitter type="area"><rgb name="radiance" value="{scaled(c, e)}"/></emitter></shape>')
    if kind == "point":
        e = R.uniform(3, 20)
        return (f'<emitter type="point"><point name="position" x="{f(R.uniform(-1.5, 1.5))}" y="{f(R.uniform(1.5, 3))}" z="{f(R.uniform(-1, 2))}"/>'
                f'<rgb name="intensity" value="{scaled(c, e)}"/></emitter>')
    if kind == "spot":
        e = R.uniform(5, 30)
        return (f'<emitter type="spot"><transform name="to_world"><lookat origin="{f(R.uniform(-1.5, 1.5))}, {f(R.uniform(2, 3))}, {f(R.uniform(-1, 2))}" target="{f(R.uniform(-0.5, 0.5))}, 0, {f(R.uniform(-0.5, 0.5))}"/></transform>'
                f'<float name="cutoff_angle" value="{f(R.uniform(15, 50))}"/><float name="beam_width" value="{f(R.uniform(5, 14))}"/>'
                f'<rgb name="intensity" value="{scaled(c, e)}"/></emitter>')
    if kind == "directional":
        e = R.uniform(1, 4)
        return (f'<emitter type="directional"><vector name="direction" x="{f(R.uniform(-1, 1))}" y="-1" z="{f(R.uniform(-1, 1))}"/>'
                f'<rgb name="irradiance" value="{scaled(c, e)}"/></emitter>')
    if kind == "constant":
        return f'<emitter type="constant"><rgb name="radiance" value="{rgb(0.1, 0.8)}"/></emitter>'
    return (f'<emitter type="envmap"><string name="filename" value="sky.exr"/><float name="scale" value="{f(R.uniform(0.3, 2))}"/>'
            f'<transform name="to_world"><rotate y="1" angle="{f(R.uniform(0, 360))}"/></transform></emitter>')


def scale_scene(text, s, spd_dir):
    """The scene scaled by s about the origin: every length times s (shapes and instances, the camera,
    point, spot and projector positions, clipping planes, a thin lens's aperture and focus, a bump map's
    height), point, spot and projector intensities times s^2 and media's absorption over s, so that the
    image is the same."""
    root = ET.fromstring(text)

    def g(x):
        return f"{x:.7g}"

    def times(value, k):
        return ", ".join(g(float(v) * k) for v in value.split(","))

    def to_world(node):
        t = node.find('transform[@name="to_world"]')
        if t is None:
            t = ET.SubElement(node, "transform", {"name": "to_world"})
        return t

    def lookat(node):
        for la in to_world(node).iter("lookat"):
            la.set("origin", times(la.get("origin"), s))
            la.set("target", times(la.get("target"), s))

    def scale_prop(node, name, k, default=1.0):
        p = node.find(f'float[@name="{name}"]')
        if p is None:
            p = ET.SubElement(node, "float", {"name": name, "value": g(default)})
        p.set("value", g(float(p.get("value")) * k))

    def intensity(node, name):
        p = node.find(f'*[@name="{name}"]')
        k = s * s
        if p is None:
            ET.SubElement(node, "float", {"name": name, "value": g(k)})
        elif p.get("filename"):
            src = os.path.join(spd_dir, p.get("filename"))
            dst = p.get("filename").replace(".spd", f"-x{g(k)}.spd")
            with open(src) as fh, open(os.path.join(spd_dir, dst), "w") as out:
                for line in fh:
                    w = line.split()
                    out.write(line if line.startswith("#") or len(w) != 2 else f"{w[0]} {float(w[1]) * k!r}\n")
            p.set("filename", dst)
        elif ":" in p.get("value"):
            p.set("value", ", ".join(f"{w.split(':')[0].strip()}:{float(w.split(':')[1]) * k!r}"
                                     for w in p.get("value").split(",")))
        else:
            p.set("value", times(p.get("value"), k))

    for node in root:
        if node.tag == "shape" and node.get("type") != "shapegroup":
            ET.SubElement(to_world(node), "scale", {"value": g(s)})
        elif node.tag == "sensor":
            lookat(node)
            for sc in to_world(node).findall("scale"):  # an orthographic film's size
                for axis in ("x", "y", "value"):
                    if sc.get(axis) is not None:
                        sc.set(axis, g(float(sc.get(axis)) * s))
            scale_prop(node, "near_clip", s, 0.01)
            scale_prop(node, "far_clip", s, 10000.0)
            for name in ("aperture_radius", "focus_distance"):
                if node.find(f'float[@name="{name}"]') is not None:
                    scale_prop(node, name, s)
        elif node.tag == "emitter" and node.get("type") == "point":
            pos = node.find('point[@name="position"]')
            for axis in ("x", "y", "z"):
                pos.set(axis, g(float(pos.get(axis, "0")) * s))
            intensity(node, "intensity")
        elif node.tag == "emitter" and node.get("type") == "spot":
            lookat(node)
            intensity(node, "intensity")
        elif node.tag == "emitter" and node.get("type") == "projector":
            lookat(node)
            scale_prop(node, "scale", s * s)
    for medium in root.iter("medium"):
        scale_prop(medium, "scale", 1 / s)
    for bump in root.iter("bsdf"):
        if bump.get("type") == "bumpmap":
            scale_prop(bump, "scale", s)
    return ET.tostring(root, encoding="unicode")


RAW = '<boolean name="raw" value="true"/>'


def more_bsdf():
    """A BSDF that reads label.png (colours as sRGB, a rough conductor's alpha as raw data)."""
    tex = lambda name, raw="": (f'<texture type="bitmap" name="{name}"><string name="filename" value="label.png"/>{raw}'
                                f'<transform name="to_uv"><scale x="{f(M.uniform(1, 3))}" y="{f(M.uniform(1, 3))}"/></transform></texture>')
    k = M.choice(["diffuse", "plastic", "principled", "roughconductor", "dielectric"])
    if k == "diffuse":
        return f'<bsdf type="diffuse">{tex("reflectance")}</bsdf>'
    if k == "plastic":
        return f'<bsdf type="plastic">{tex("diffuse_reflectance")}<float name="int_ior" value="{f(M.uniform(1.3, 1.8))}"/></bsdf>'
    if k == "principled":
        return (f'<bsdf type="principled">{tex("base_color")}<float name="roughness" value="{f(M.uniform(0.1, 0.9))}"/>'
                f'<float name="metallic" value="{f(M.uniform(0, 1))}"/></bsdf>')
    if k == "roughconductor":
        return (f'<bsdf type="roughconductor"><string name="material" value="{M.choice(["Au", "Cu", "Al"])}"/>'
                f'<string name="distribution" value="ggx"/>{tex("alpha", RAW)}</bsdf>')
    return f'<bsdf type="dielectric"><string name="int_ior" value="{M.choice(["water", "bk7", "diamond", "acrylic glass"])}"/></bsdf>'


def more():
    """The extras of --more: an emitting mesh or cube/disk/cylinder, a textured object."""
    out = []
    kind = M.choice(["cube", "disk", "cylinder", "ply", "obj"])
    s = [M.uniform(0.1, 0.35) for _ in range(3)]
    if kind == "cylinder":
        # Mitsuba's cylinder takes its radius from to_world's x scale: with another y scale its
        # intersection is an elliptic tube but its emitter samples a round one (it warns).
        s[1] = s[0]
    rot = (M.uniform(60, 120), M.uniform(0, 90), M.uniform(-30, 30))
    at = (M.uniform(-1.2, 1.2), M.uniform(1.6, 2.6), M.uniform(-0.8, 1.0))
    body = {"ply": '<string name="filename" value="ball.ply"/>',
            "obj": '<string name="filename" value="tile.obj"/>'}.get(kind, "")
    out.append(f'<shape type="{kind}">{body}{transform(s, *rot, at)}<bsdf type="diffuse"/>'
               f'<emitter type="area"><rgb name="radiance" value="{", ".join(f(M.uniform(2, 12)) for _ in range(3))}"/></emitter></shape>')
    kind = M.choice(["sphere", "cube", "ply", "rectangle"])
    x, z = M.uniform(-1.3, 1.3), M.uniform(-1.0, 1.0)
    if kind == "sphere":
        r = M.uniform(0.2, 0.45)
        out.append(f'<shape type="sphere">{transform((r, r, r), 0, M.uniform(0, 360), 0, (x, r + 0.02, z))}{more_bsdf()}</shape>')
    elif kind == "ply":
        r = M.uniform(0.2, 0.45)
        out.append(f'<shape type="ply"><string name="filename" value="ball.ply"/>{transform((r, r * M.uniform(0.5, 1.5), r), 0, M.uniform(0, 90), 0, (x, r * 1.6 + 0.02, z))}{more_bsdf()}</shape>')
    else:
        s = [M.uniform(0.15, 0.45) for _ in range(3)]
        out.append(f'<shape type="{kind}">{transform(s, M.uniform(-40, 40), M.uniform(0, 90), 0, (x, max(s) * 1.8 + 0.02, z))}{more_bsdf()}</shape>')
    return out


w, h = 64, 48
depth = R.choice([2, 3, 5, 8, 12, -1])
hide = R.random() < 0.2
filt = R.choice(["box", "box", "gaussian", "tent"])
parts = [f'<scene version="3.0.0"><default name="spp" value="64"/>',
         f'<integrator type="path"><integer name="max_depth" value="{depth}"/>'
         f'<boolean name="hide_emitters" value="{"true" if hide else "false"}"/></integrator>',
         f'<sensor type="perspective"><float name="fov" value="{f(R.uniform(35, 60))}"/>'
         f'<transform name="to_world"><lookat origin="{f(R.uniform(-1, 1))}, {f(R.uniform(1.2, 2.5))}, {f(R.uniform(3.5, 5))}" target="0, 0.4, 0" up="0, 1, 0"/></transform>'
         f'<sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>'
         f'<film type="hdrfilm"><integer name="width" value="{w}"/><integer name="height" value="{h}"/>'
         f'<rfilter type="{filt}"/></film></sensor>',
         # floor
         f'<shape type="rectangle"><transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>{bsdf(allow_glass=False)}</shape>']
if R.random() < 0.5:
    parts.append(f'<shape type="rectangle"><transform name="to_world"><scale x="4" y="2.5"/><translate y="2" z="-2"/></transform>{bsdf(allow_glass=False)}</shape>')
for _ in range(R.randint(1, 4)):
    parts.append(obj())
envs = 0
for _ in range(R.randint(1, 2)):
    e = emitter()
    if 'type="constant"' in e or 'type="envmap"' in e:
        envs += 1
        if envs > 1:
            continue
    parts.append(e)
if args.more:
    parts += more()
parts.append("</scene>")
text = "\n".join(parts) + "\n"
if args.more:
    text = text.replace('<rfilter type="' + filt + '"/>', f'<rfilter type="{M.choice(["mitchell", "lanczos", "catmullrom", filt])}"/>', 1)
    text = text.replace('<float name="fov"', f'<string name="fov_axis" value="{M.choice(["x", "y", "diagonal", "smaller", "larger"])}"/><float name="fov"', 1)
    if M.random() < 0.5:
        text = text.replace('<sensor type="perspective">', '<sensor type="thinlens">'
                            f'<float name="aperture_radius" value="{f(M.uniform(0.01, 0.08))}"/>'
                            f'<float name="focus_distance" value="{f(M.uniform(3, 5))}"/>', 1)
    # Spectra for some colours, from a third stream (the rest of the scene stays the seed's): a
    # constant (inside an emitter a flat spectrum: slightly purple in sRGB) or wavelength:value pairs,
    # inline or in a .spd file beside OUT.
    S = random.Random(args.seed * 104729 + 3)
    spd_files = []

    def as_spectrum(m):
        name, values = m.group(1), [float(v) for v in m.group(2).split(",")]
        if S.random() > 0.35 or len(values) != 3:
            return m.group(0)
        mean = sum(values) / 3
        if S.random() < 0.4 or name == "specular_reflectance":
            return f'<spectrum name="{name}" value="{f(mean)}"/>'
        waves = sorted(S.sample(range(360, 831, 5), S.randint(2, 6)))
        top = 1.0 if name not in ("eta", "k", "radiance", "intensity", "irradiance") else float("inf")
        pairs = [(w, min(top, mean * S.uniform(0.2, 1.8))) for w in waves]
        if S.random() < 0.3:
            spd = f"spectrum-{args.seed}-{len(spd_files)}.spd"
            spd_files.append((spd, "".join(f"{w} {f(v)}\n" for w, v in pairs)))
            return f'<spectrum name="{name}" filename="{spd}"/>'
        return f'<spectrum name="{name}" value="{", ".join(f"{w}:{f(v)}" for w, v in pairs)}"/>'

    text = re.sub(r'<rgb name="(\w+)" value="([^"]*)"/>', as_spectrum, text)
    # Half the twosided BSDFs get a second, opaque BSDF for their front (the one there becomes their
    # back), drawn from a fourth stream, after the spectra, so the rest stays what the seed made.
    T = random.Random(args.seed * 7919 + 5)

    def two_faced(m):
        global R
        if T.random() >= 0.5:
            return m.group(0)
        R, kept = T, R
        front = bsdf(1, False)
        R = kept
        return m.group(0) + front

    text = re.sub(r'<bsdf type="twosided">', two_faced, text)
    # Some area emitters get a texture for their radiance, from a fifth stream: a checkerboard (Mitsuba
    # holds its colours to [0, 1] there), the HDR sky.exr or label.png. Only on rectangles and spheres:
    # Mitsuba 3.9.1 draws a point on a textured emitter by its texture and places it by its uv, which
    # on a cube (six faces sharing the uv square) reaches one face and reads the light biased dark
    # (README, "Textured emitters"), and fails on a mesh without texture coordinates.
    U = random.Random(args.seed * 6271 + 11)

    def textured_light(m):
        if m.group(1) not in ("rectangle", "sphere") or U.random() >= 0.4:
            return m.group(0)
        k = U.choice(["checkerboard", "sky.exr", "label.png"])
        if k == "checkerboard":
            c0 = ", ".join(f(U.uniform(0.1, 1.0)) for _ in range(3))
            c1 = ", ".join(f(U.uniform(0.1, 1.0)) for _ in range(3))
            s = U.choice([2, 3, 5])
            tex = checkerboard("radiance", c0, c1, s, s)
        else:
            tex = bitmap("radiance", k)
        return m.group(0).replace(m.group(2), tex)

    text = re.sub(r'<shape type="(\w+)">.*?<emitter type="area">(<(?:rgb|spectrum) name="radiance"[^>]*/>)</emitter>',
                  textured_light, text)
    # Some shapes with texture coordinates get a normal map over their BSDF, from a sixth stream:
    # bumps.exr (raw, repeated 1 to 3 times, sometimes read nearest), around the BSDF or, inside a twosided of
    # one BSDF, around that one (the back then the front's mirror image). Not over blends, masks,
    # panes or two-BSDF twosided (caustica refuses those), nor on the PLY ball or a cylinder (no
    # texture coordinates).
    N = random.Random(args.seed * 3571 + 29)
    MAPPABLE = ("diffuse", "plastic", "roughplastic", "conductor", "roughconductor", "dielectric",
                "roughdielectric", "principled")

    def element_end(t, i):
        """The index just past the <bsdf> element that starts at t[i]."""
        depth = 0
        for m in re.finditer(r'<bsdf\b[^>]*?(/?)>|</bsdf>', t[i:]):
            if m.group(0) == "</bsdf>":
                depth -= 1
            elif m.group(1) != "/":
                depth += 1
            if depth == 0:
                return i + m.end()
        raise ValueError("unbalanced <bsdf>")

    def normal_map_texture():
        # bumps.exr (Mitsuba's checkerboard has no eval_3, which its normalmap calls).
        s = N.choice([1, 2, 3])
        nearest = '<string name="filter_type" value="nearest"/>' if N.random() < 0.3 else ""
        return (f'<texture type="bitmap" name="normalmap"><string name="filename" value="bumps.exr"/>'
                f'<boolean name="raw" value="true"/>{nearest}<transform name="to_uv"><scale x="{s}" y="{s}"/></transform></texture>')

    def mappable(line):
        """(i, j, outer, inner) for the first <bsdf> element of `line` (line[i:j] = outer) where a normal
        or bump map can go: inner None where outer is itself MAPPABLE, else the one MAPPABLE BSDF of the
        twosided that outer is; None where neither holds."""
        i = line.find("<bsdf")
        if i < 0:
            return None
        j = element_end(line, i)
        outer = line[i:j]
        kind = re.match(r'<bsdf type="(\w+)"', outer).group(1)
        if kind in MAPPABLE:
            return i, j, outer, None
        if kind != "twosided":
            return None
        k = outer.find("<bsdf", 1)
        inner = outer[k:element_end(outer, k)]
        if len(inner) + len('<bsdf type="twosided">') + len("</bsdf>") != len(outer):
            return None  # two BSDFs
        if re.match(r'<bsdf type="(\w+)"', inner).group(1) not in MAPPABLE:
            return None
        return i, j, outer, inner

    def normal_mapped(line):
        m = re.match(r'<shape type="(\w+)">', line)
        if not m or m.group(1) not in ("rectangle", "cube", "disk", "sphere", "obj") or N.random() >= 0.35:
            return line
        found = mappable(line)
        if not found:
            return line
        i, j, outer, inner = found
        if inner is None:
            mapped = f'<bsdf type="normalmap">{normal_map_texture()}{outer}</bsdf>'
        elif N.random() < 0.5:
            mapped = f'<bsdf type="twosided"><bsdf type="normalmap">{normal_map_texture()}{inner}</bsdf></bsdf>'
        else:
            mapped = f'<bsdf type="normalmap">{normal_map_texture()}{outer}</bsdf>'
        return line[:i] + mapped + line[j:]

    text = "\n".join(normal_mapped(line) for line in text.split("\n"))

    # Some rough conductors and dielectrics get an anisotropic roughness (alpha_u along the shape's
    # ∂p/∂u, alpha_v across it), and some principled BSDFs an `anisotropic`, from a seventh stream: not
    # on a cylinder (caustica's has no ∂p/∂u).
    A = random.Random(args.seed * 6133 + 41)
    # A rough conductor's or dielectric's opening up to its number alpha (group 1), and that number (2).
    ROUGH_ALPHA = re.compile(r'(<bsdf type="rough(?:conductor|dielectric)">(?:(?!</bsdf>).)*?)<float name="alpha" value="([^"]+)"/>')

    def anisotropic(m):
        if A.random() >= 0.6:
            return m.group(0)
        alpha, other = m.group(2), f(A.uniform(0.02, 0.5))
        u, v = (alpha, other) if A.random() < 0.5 else (other, alpha)
        return m.group(1) + f'<float name="alpha_u" value="{u}"/><float name="alpha_v" value="{v}"/>'

    def anisotropic_principled(m):
        if A.random() >= 0.5:
            return m.group(0)
        return m.group(0) + f'<float name="anisotropic" value="{f(A.uniform(0.1, 1.0))}"/>'

    def anisotropic_line(line):
        if line.startswith('<shape type="cylinder"'):
            return line
        line = ROUGH_ALPHA.sub(anisotropic, line)
        return re.sub(r'<bsdf type="principled">', anisotropic_principled, line)

    text = "\n".join(anisotropic_line(line) for line in text.split("\n"))

    # Cylinders (texture coordinates in caustica since session 43), from an eighth stream so that the
    # streams above stay as they were: half of them get a normal map over their BSDF, or, if it is a
    # rough conductor or dielectric or a principled BSDF, an anisotropic roughness instead.
    C = random.Random(args.seed * 2741 + 53)

    def cylinder_extra(line):
        if not line.startswith('<shape type="cylinder"') or C.random() >= 0.5:
            return line
        rough = ROUGH_ALPHA.sub(lambda m: m.group(1) + f'<float name="alpha_u" value="{m.group(2)}"/>'
                                f'<float name="alpha_v" value="{f(C.uniform(0.02, 0.5))}"/>', line, count=1)
        if rough != line:
            return rough
        if '<bsdf type="principled">' in line:
            return line.replace('<bsdf type="principled">', f'<bsdf type="principled"><float name="anisotropic" value="{f(C.uniform(0.1, 1.0))}"/>', 1)
        i = line.find("<bsdf")
        if i < 0:
            return line
        j = element_end(line, i)
        outer = line[i:j]
        if re.match(r'<bsdf type="(\w+)"', outer).group(1) not in MAPPABLE:
            return line
        return line[:i] + f'<bsdf type="normalmap">{normal_map_texture()}{outer}</bsdf>' + line[j:]

    text = "\n".join(cylinder_extra(line) for line in text.split("\n"))

    # An orthographic camera (caustica since session 44) for a quarter of the pinhole cameras, from a
    # ninth stream so that the streams above stay as they were: the same place and view, a film 3 to
    # 4.4 wide whose y scale differs from its x scale by up to 25% (pixels not square).
    O = random.Random(args.seed * 1319 + 67)
    if '<sensor type="perspective">' in text and O.random() < 0.25:
        sx = O.uniform(1.5, 2.2)
        sy = sx * O.uniform(0.8, 1.25)
        text = text.replace('<sensor type="perspective">', '<sensor type="orthographic">', 1)
        text = re.sub(r'<string name="fov_axis" value="\w+"/>', '', text, count=1)
        text = re.sub(r'<float name="fov" value="[^"]*"/>', '', text, count=1)
        text = text.replace('<transform name="to_world"><lookat',
                            f'<transform name="to_world"><scale x="{f(sx)}" y="{f(sy)}"/><lookat', 1)
    # Textured anisotropic roughness (caustica since session 44), from a tenth stream, last: a third of
    # the numbers `alpha_u` or `alpha_v` become a checkerboard of that number and another in [0.02, 0.5]
    # (Mitsuba reads a texture there as one number, its `eval_1`).
    X = random.Random(args.seed * 4327 + 71)

    def textured_alpha(m):
        if X.random() >= 1 / 3:
            return m.group(0)
        scale = X.choice([2, 3, 5, 8])
        return checkerboard(m.group(1), m.group(2), f(X.uniform(0.02, 0.5)), scale)

    text = re.sub(r'<float name="(alpha_[uv])" value="([^"]+)"/>', textured_alpha, text)

    # Spots projecting a texture (caustica since session 44), from an eleventh stream, last: half the
    # spots throw label.png (bilinear or nearest) or a checkerboard of two colours.
    P = random.Random(args.seed * 9257 + 83)

    def slide(m):
        if P.random() >= 0.5:
            return m.group(0)
        if P.random() < 0.5:
            filt = P.choice(["bilinear", "nearest"])
            tex = (f'<texture type="bitmap" name="texture"><string name="filename" value="label.png"/>'
                   f'<string name="filter_type" value="{filt}"/></texture>')
        else:
            c0 = ", ".join(f(P.uniform(0.1, 1.0)) for _ in range(3))
            c1 = ", ".join(f(P.uniform(0.1, 1.0)) for _ in range(3))
            tex = checkerboard("texture", c0, c1, P.choice([2, 3, 4]))
        return m.group(0)[:-len("</emitter>")] + tex + "</emitter>"

    text = re.sub(r'<emitter type="spot">(?:(?!</emitter>).)*</emitter>', slide, text)
    # A crop window (caustica since session 45) for a third of the scenes, from a twelfth stream, last:
    # the film 1.2 to 2 times as large each way, the image its 64 x 48 window somewhere on it; and for
    # half the pinhole cameras a principal point offset of up to 0.3 of the film each way.
    Q = random.Random(args.seed * 7717 + 89)
    if Q.random() < 1 / 3:
        k = Q.uniform(1.2, 2.0)
        fw, fh = round(w * k), round(h * k)
        ox, oy = Q.randint(0, fw - w), Q.randint(0, fh - h)
        text = text.replace(f'<integer name="width" value="{w}"/><integer name="height" value="{h}"/>',
                            f'<integer name="width" value="{fw}"/><integer name="height" value="{fh}"/>'
                            f'<integer name="crop_offset_x" value="{ox}"/><integer name="crop_offset_y" value="{oy}"/>'
                            f'<integer name="crop_width" value="{w}"/><integer name="crop_height" value="{h}"/>', 1)
    if '<sensor type="perspective">' in text and Q.random() < 0.5:
        px, py = Q.uniform(-0.3, 0.3), Q.uniform(-0.3, 0.3)
        text = text.replace('<sensor type="perspective">', '<sensor type="perspective">'
                            f'<float name="principal_point_offset_x" value="{f(px)}"/>'
                            f'<float name="principal_point_offset_y" value="{f(py)}"/>', 1)
    # Vertex colours (caustica since session 45), from a thirteenth stream, last: half the PLY balls
    # become colored-ball.ply (float colours), and the colour of their diffuse reflectance, principled
    # base colour, conductor's specular reflectance or dielectric's transmittance becomes its vertex
    # colours times a scale in [0.5, 1] (Mitsuba's plastics cannot read a mesh_attribute).
    V = random.Random(args.seed * 6151 + 97)

    def colored(line, rng, mesh, attribute):
        """Half the time, `line`'s ball.ply becomes `mesh`, and the first colour its BSDF reads becomes
        the mesh's `attribute` times a scale in [0.5, 1]."""
        if 'value="ball.ply"' not in line or rng.random() >= 0.5:
            return line
        line = line.replace('value="ball.ply"', f'value="{mesh}"', 1)
        # Which colour of which BSDF (the first such colour after its opening tag, no BSDF between).
        reads = {"diffuse": "reflectance", "principled": "base_color", "conductor": "specular_reflectance",
                 "roughconductor": "specular_reflectance", "dielectric": "specular_transmittance",
                 "roughdielectric": "specular_transmittance", "thindielectric": "specular_transmittance"}

        def attr(m):
            return (f'{m.group(1)}<texture type="mesh_attribute" name="{m.group(3)}">'
                    f'<string name="name" value="{attribute}"/><float name="scale" value="{f(rng.uniform(0.5, 1.0))}"/></texture>')

        def one(m):
            if reads.get(m.group(2)) != m.group(3):
                return m.group(0)
            return attr(m)
        return re.sub(r'(<bsdf type="(\w+)">(?:(?!<bsdf).)*?)<rgb name="(\w+)" value="[^"]*"/>', one, line)

    text = "\n".join(colored(line, V, "colored-ball.ply", "vertex_color") for line in text.split("\n"))
    # Bump maps (caustica since session 46), from a fourteenth stream, last: about a quarter of the
    # shapes with texture coordinates (not disks, whose triangles caustica refuses to bump, nor shapes
    # with a normal map already) get a bumpmap over their BSDF, or inside a twosided of one around that
    # one: height.png (raw, repeated 1 to 3 times) or label.png (sRGB, by luminance), a scale of either
    # sign.
    B = random.Random(args.seed * 4877 + 53)

    def bump_texture():
        if B.random() < 0.7:
            s = B.choice([1, 2, 3])
            return (f'<texture type="bitmap"><string name="filename" value="height.png"/><boolean name="raw" value="true"/>'
                    f'<transform name="to_uv"><scale x="{s}" y="{s}"/></transform></texture>'
                    f'<float name="scale" value="{f(B.choice([-1, 1]) * B.uniform(0.01, 0.06))}"/>')
        return (f'<texture type="bitmap"><string name="filename" value="label.png"/></texture>'
                f'<float name="scale" value="{f(B.choice([-1, 1]) * B.uniform(0.02, 0.1))}"/>')

    def bumped(line):
        m = re.match(r'<shape type="(\w+)">', line)
        if (not m or m.group(1) not in ("rectangle", "cube", "sphere", "cylinder", "obj")
                or 'type="normalmap"' in line or B.random() >= 0.25):
            return line
        found = mappable(line)
        if not found:
            return line
        i, j, outer, inner = found
        if inner is None:
            return line[:i] + f'<bsdf type="bumpmap">{bump_texture()}{outer}</bsdf>' + line[j:]
        return line[:i] + f'<bsdf type="twosided"><bsdf type="bumpmap">{bump_texture()}{inner}</bsdf></bsdf>' + line[j:]

    text = "\n".join(bumped(line) for line in text.split("\n"))
    # Wrap modes (caustica since session 46), from a fifteenth stream, last: a third of the bitmap
    # textures read clamp or mirror beyond their edges (what repeat tiles).
    X = random.Random(args.seed * 2609 + 71)

    def wrapped(m):
        if X.random() >= 1 / 3:
            return m.group(0)
        return m.group(0) + f'<string name="wrap_mode" value="{X.choice(["clamp", "mirror"])}"/>'

    text = re.sub(r'<texture type="bitmap"[^>]*>', wrapped, text)
    # Face colours (caustica since session 47), from a sixteenth stream, last: half the PLY balls left
    # become facets.ply (flat faces with 16-bit colours), their BSDF's colour its face colours, as the
    # thirteenth stream gives vertex colours.
    C = random.Random(args.seed * 3203 + 29)
    text = "\n".join(colored(line, C, "facets.ply", "face_color") for line in text.split("\n"))
    # Textured principled weights (caustica since session 47), from a seventeenth stream, last: each
    # number a principled BSDF gives metallic, spec_trans, spec_tint, sheen, sheen_tint, flatness,
    # clearcoat or clearcoat_gloss becomes, three times in ten, a checkerboard of it and another value
    # (read by Mitsuba's eval_1, which swaps a checkerboard's colours) or label.png (by luminance).
    W = random.Random(args.seed * 7919 + 11)

    def weight_texture(m):
        if W.random() >= 0.3:
            return m.group(0)
        name, value = m.group(1), m.group(2)
        if W.random() < 0.7:
            s = W.choice([2, 3, 5])
            return checkerboard(name, value, f(W.uniform(0.0, 1.0)), s, s, kind="float")
        return bitmap(name, "label.png")

    weights = "metallic|spec_trans|spec_tint|sheen|sheen_tint|flatness|clearcoat|clearcoat_gloss"
    text = re.sub(rf'<float name="({weights})" value="([^"]*)"/>', weight_texture, text)
    # A textured principled `anisotropic` (caustica since session 48), from an eighteenth stream, last:
    # half the principled BSDFs the seventh stream made anisotropic get a checkerboard of their value
    # and 0 to 1 instead (patches brushed beside isotropic ones), or label.png.
    W = random.Random(args.seed * 5651 + 13)

    def anisotropic_texture(m):
        if W.random() >= 0.5:
            return m.group(0)
        if W.random() < 0.75:
            s = W.choice([2, 4, 6])
            return checkerboard("anisotropic", m.group(1), f(W.uniform(0.0, 1.0)), s, s // 2, kind="float")
        return bitmap("anisotropic", "label.png")

    text = re.sub(r'<float name="anisotropic" value="([^"]*)"/>', anisotropic_texture, text)
    # Clipping planes (caustica since session 49), from a nineteenth stream, last: a third of the scenes
    # get a near plane 1.5 to 4.5 from the lens (the camera stands 3.7 to 5.3 from the scene's middle,
    # so it cuts into some shapes and the floor), and half of those, or a sixth of the rest, a far plane
    # 3 to 7 away (the far floor, the back wall and the sky behind them).
    C = random.Random(args.seed * 4271 + 31)
    clip = ""
    near = 0.01
    if C.random() < 1 / 3:
        near = C.uniform(1.5, 4.5)
        clip += f'<float name="near_clip" value="{f(near)}"/>'
    if C.random() < (0.5 if clip else 1 / 6):
        far = max(C.uniform(3.0, 7.0), near + 0.5)
        clip += f'<float name="far_clip" value="{f(far)}"/>'
    if clip:
        text = re.sub(r'<sensor type="(\w+)">', lambda m: m.group(0) + clip, text, count=1)
    # Projectors (caustica since session 60), from a twentieth stream, last: a third of the spots become
    # projectors along the same lookat, 20 to 70 degrees wide along a random fov_axis, throwing their
    # slide (as `irradiance`, scaled by the spot's mean intensity) or their colour, with scale 1/pi (the
    # spot's intensity on the axis).
    J = random.Random(args.seed * 8861 + 37)

    def projector(m):
        if J.random() >= 1 / 3:
            return m.group(0)
        body = m.group(0)
        # The intensity: an <rgb>, or (the spectra stream) a <spectrum> of pairs or of a file.
        rgb = re.search(r'<(?:rgb|spectrum) name="intensity" (?:value|filename)="([^"]*)"/>', body)
        body = re.sub(r'<float name="(cutoff_angle|beam_width)" value="[^"]*"/>', "", body)
        fov = (f'<float name="fov" value="{f(J.uniform(20, 70))}"/>'
               f'<string name="fov_axis" value="{J.choice(["x", "y", "diagonal", "smaller", "larger"])}"/>')
        if 'name="texture"' in body and not rgb.group(0).startswith("<rgb"):
            return m.group(0)  # a slide scaled by a spectrum's mean: left a spot
        if 'name="texture"' in body:
            mean = sum(float(v) for v in rgb.group(1).split(",")) / 3
            body = body.replace(rgb.group(0), f'<float name="scale" value="{f(mean / 3.141592653589793)}"/>')
            body = body.replace('name="texture"', 'name="irradiance"')
        else:
            body = body.replace(rgb.group(0), f'<float name="scale" value="{f(1 / 3.141592653589793)}"/>'
                                + rgb.group(0).replace('name="intensity"', 'name="irradiance"'))
        return body.replace('<emitter type="spot">', '<emitter type="projector">' + fov, 1)

    text = re.sub(r'<emitter type="spot">(?:(?!</emitter>).)*</emitter>', projector, text)
    # Coloured glass (caustica since session 61), from a twenty-first stream, last: four in five closed
    # shapes (sphere, cube, a PLY ball) whose own BSDF is a smooth or rough dielectric get an interior
    # `homogeneous` medium of albedo 0 (a colour in [0, 1] times a scale of 0.5 to 5 per unit length),
    # nested or by <ref> to a top-level one; the integrator is then volpath (path ignores media).
    V = random.Random(args.seed * 9973 + 41)
    # --scatter's own stream (session 76), so that the media's absorption stays what the seed gives.
    W = random.Random(args.seed * 7331 + 53)
    media = []

    def glass_instead(body):
        """--scatter: half the closed shapes' outermost BSDF (nested ones too, its whole element)
        becomes a smooth or rough glass, so that more of them hold a medium."""
        start = body.find("<bsdf")
        if start < 0 or W.random() >= 0.5:
            return body
        depth, k = 0, start
        for t in re.finditer(r"<(/?)bsdf\b[^>]*?(/?)>", body[start:]):
            if t.group(1):
                depth -= 1
            elif not t.group(2):
                depth += 1
            if depth == 0:
                k = start + t.end()
                break
        else:
            return body
        ior = f(W.uniform(1.1, 1.8))
        glass = W.choice([f'<bsdf type="dielectric"><float name="int_ior" value="{ior}"/></bsdf>',
                          f'<bsdf type="roughdielectric"><float name="alpha" value="{f(W.uniform(0.05, 0.4))}"/>'
                          f'<float name="int_ior" value="{ior}"/></bsdf>'])
        return body[:start] + glass + body[k:]

    def coloured(m):
        body = m.group(0)
        closed = m.group(1) in ("sphere", "cube") or re.search(r'value="[\w-]*ball\.ply"', body)
        if args.scatter and closed and "<emitter" not in body and "<bsdf" in body:
            body = glass_instead(body)
        first = re.search(r'<bsdf type="(\w+)"', body)
        if not closed or "<emitter" in body or not first or first.group(1) not in ("dielectric", "roughdielectric"):
            return body
        if V.random() >= 0.8 and not args.scatter:
            return body
        sigma = ", ".join(f(V.uniform(0.0, 1.0)) for _ in range(3))
        albedo = V.choice(['<float name="albedo" value="0"/>', '<rgb name="albedo" value="0, 0, 0"/>'])
        if args.scatter:
            # A medium that scatters: σ_t's channels within five times each other (Mitsuba's volpath draws
            # one channel's free flights a path, whose weights in the others grow with their difference
            # and leave its images slow to converge), an albedo of 0.3 to 1 a channel, and a phase
            # function, isotropic (written or by default) or Henyey-Greenstein.
            sigma = ", ".join(f(W.uniform(0.2, 1.0)) for _ in range(3))
            albedo = f'<rgb name="albedo" value="{", ".join(f(W.uniform(0.3, 1.0)) for _ in range(3))}"/>'
            albedo += W.choice(["", '<phase type="isotropic"/>',
                                f'<phase type="hg"><float name="g" value="{f(W.uniform(-0.7, 0.9))}"/></phase>'])
        props = f'<rgb name="sigma_t" value="{sigma}"/>{albedo}<float name="scale" value="{f(V.uniform(0.5, 5.0))}"/>'
        if V.random() < 0.5:
            medium = f'<medium type="homogeneous" name="interior">{props}</medium>'
        else:
            mid = f"medium{len(media)}"
            media.append(f'<medium type="homogeneous" id="{mid}">{props}</medium>')
            medium = f'<ref name="interior" id="{mid}"/>'
        return body[: -len("</shape>")] + medium + "</shape>"

    text = re.sub(r'<shape type="(\w+)">(?:(?!</shape>).)*</shape>', coloured, text)
    if media:
        text = re.sub(r'(<integrator type=")path(")', r"\1volpath\2", text, count=1)
        text = re.sub(r"(</sensor>\n?)", lambda m: m.group(1) + "".join(media), text, count=1)
    # Mirroring transforms (session 62), from a twenty-second stream, last: a fourth of the rectangles,
    # disks, cubes and PLY and OBJ meshes get a scale of -1 along x, y or z before their own to_world
    # (Mitsuba renders a mesh without vertex normals, or with face_normals, inside out then, as the
    # import does), but not a shape with a medium, whose media Mitsuba swaps, nor a sphere or cylinder,
    # which it does not mirror as a surface (README "Not done": the import warns of those).
    Y = random.Random(args.seed * 5281 + 43)

    def mirrored(m):
        body = m.group(0)
        if m.group(1) not in ("rectangle", "disk", "cube", "ply", "obj") or Y.random() >= 0.25:
            return body
        axis = Y.choice("xyz")
        if "<medium" in body or 'name="interior"' in body:
            return body
        if '<transform name="to_world">' not in body:
            return body.replace(">", f'><transform name="to_world"><scale {axis}="-1"/></transform>', 1)
        return body.replace('<transform name="to_world">', f'<transform name="to_world"><scale {axis}="-1"/>', 1)

    text = re.sub(r'<shape type="(\w+)">(?:(?!</shape>).)*</shape>', mirrored, text)
    # Spheres turned inside out (session 63), from a twenty-third stream, last: a fifth of the spheres
    # that neither emit nor hold a medium get flip_normals, another fifth a mirroring scale (Mitsuba's
    # normals then turn inward, as the import's do), and one in ten both (facing out again). Not one
    # with a medium: its inside would be the whole scene outside it, which Mitsuba follows past every
    # other surface.
    F = random.Random(args.seed * 7919 + 61)

    def inside_out(m):
        body = m.group(0)
        if m.group(1) != "sphere" or "<emitter" in body or "<medium" in body or 'name="interior"' in body:
            return body
        u = F.random()
        flip = u < 0.2 or 0.4 <= u < 0.5
        mirror = 0.2 <= u < 0.5
        axis = F.choice("xyz")
        if mirror:
            if '<transform name="to_world">' not in body:
                body = body.replace(">", f'><transform name="to_world"><scale {axis}="-1"/></transform>', 1)
            else:
                body = body.replace('<transform name="to_world">', f'<transform name="to_world"><scale {axis}="-1"/>', 1)
        if flip:
            body = body.replace(">", '><boolean name="flip_normals" value="true"/>', 1)
        return body

    text = re.sub(r'<shape type="(\w+)">(?:(?!</shape>).)*</shape>', inside_out, text)
    # Shapes inside a medium (session 63), from a twenty-fourth stream, last: in half the spheres, cubes
    # and PLY balls with an interior medium, a ball at their centre of 0.35 their smallest half-size, in
    # diffuse colour, rough gold or clear glass (no medium of its own: it lies in the shape's, as a
    # diffuse one does, on both of its sides).
    G = random.Random(args.seed * 6007 + 67)

    def immersed(m):
        body = m.group(0)
        if m.group(1) not in ("sphere", "cube", "ply") or 'name="interior"' not in body or G.random() >= 0.5:
            return body
        num = r"(-?[\d.e+-]+)"
        if m.group(1) == "sphere":
            c = re.search(rf'<point name="center" x="{num}" y="{num}" z="{num}"/>', body)
            r = re.search(rf'<float name="radius" value="{num}"/>', body)
            if not c or not r:
                return body
            centre, size = [float(v) for v in c.groups()], float(r.group(1))
        else:
            sc = re.search(rf'<scale x="{num}" y="{num}" z="{num}"/>', body)
            t = re.search(rf'<translate x="{num}" y="{num}" z="{num}"/>', body)
            if not sc or not t:
                return body
            centre, size = [float(v) for v in t.groups()], min(abs(float(v)) for v in sc.groups())
        inner = G.choice([
            f'<bsdf type="diffuse"><rgb name="reflectance" value="{", ".join(f(G.uniform(0.2, 0.9)) for _ in range(3))}"/></bsdf>',
            f'<bsdf type="roughconductor"><string name="material" value="Au"/><float name="alpha" value="{f(G.uniform(0.05, 0.4))}"/></bsdf>',
            '<bsdf type="dielectric"><float name="int_ior" value="1.5"/></bsdf>',
        ])
        ball = (f'<shape type="sphere"><point name="center" x="{f(centre[0])}" y="{f(centre[1])}" z="{f(centre[2])}"/>'
                f'<float name="radius" value="{f(0.35 * size)}"/>{inner}</shape>')
        return body + "\n" + ball

    text = re.sub(r'<shape type="(\w+)">(?:(?!</shape>).)*</shape>', immersed, text)
    # Textured squares (session 69), from a twenty-fifth stream, last: in half the checkerboards that
    # are a reflectance (diffuse, a plastic's base, a principled base colour), one square becomes a
    # texture read at the hit's own uv through its own to_uv: label.png, or a finer checkerboard.
    N = random.Random(args.seed * 4409 + 73)

    def nested_square(m):
        if N.random() >= 0.5:
            return m.group(0)
        which = N.choice(["color0", "color1"])
        if N.random() < 0.5:
            tex = (f'<texture type="bitmap" name="{which}"><string name="filename" value="label.png"/>'
                   f'<transform name="to_uv"><scale value="{f(N.uniform(0.5, 3))}"/></transform></texture>')
        else:
            colour = lambda: ", ".join(f(N.uniform(0.05, 0.95)) for _ in range(3))
            tex = checkerboard(which, colour(), colour(), f(N.uniform(3, 9)))
        return re.sub(rf'<(rgb|spectrum|float) name="{which}"[^>]*/>', lambda _: tex, m.group(0), count=1)

    text = re.sub(r'<texture type="checkerboard" name="(?:reflectance|diffuse_reflectance|base_color)">(?:(?!</texture>).)*</texture>',
                  nested_square, text)
    # Normals against the winding (session 71), from a twenty-sixth stream, last: three in five PLY
    # balls left become inverted-ball.ply (every vertex normal pointing in) or, without media,
    # mixed-ball.ply (every other face wound inward under outward normals): Mitsuba shades a mesh by its
    # normals and gives its media by its winding, which differ across a mixed ball's faces.
    I = random.Random(args.seed * 5381 + 19)

    def against(m):
        body = m.group(0)
        if 'value="ball.ply"' not in body or I.random() >= 0.6:
            return body
        mesh = "inverted-ball.ply" if 'name="interior"' in body or I.random() < 0.5 else "mixed-ball.ply"
        return body.replace('value="ball.ply"', f'value="{mesh}"', 1)

    text = re.sub(r'<shape type="ply">(?:(?!</shape>).)*</shape>', against, text)
    # Instances (session 72), from a twenty-seventh stream, last: a fourth of the shapes that neither
    # emit nor hold a medium (Mitsuba instances neither) go into a shapegroup placed once by an instance
    # that turns it about the vertical axis, scales it (a sphere uniformly: Mitsuba's instance makes an
    # ellipsoid of it, caustica's import refuses one) and, a third of the time, mirrors it across the
    # plane x = 0. Mitsuba transforms the rays into the group; caustica copies the shapes into place.
    # Not a shape with vertex colours, which Mitsuba reads wrongly in an instance.
    K = random.Random(args.seed * 3917 + 29)
    groups = iter(range(10**6))

    def instanced(m):
        body = m.group(0)
        if "<emitter" in body or "<medium" in body or 'name="interior"' in body or K.random() >= 0.25:
            return body
        # Mitsuba 3.9.1 reads an instanced mesh's vertex colours at barycentrics of the world-space hit
        # point against the group's untransformed triangle: wrong colours (README "Not done").
        if 'value="vertex_color"' in body:
            return body
        s = K.uniform(0.8, 1.2)
        sx, sy, sz = (s, s, s) if m.group(1) == "sphere" else (K.uniform(0.7, 1.3), K.uniform(0.8, 1.2), K.uniform(0.7, 1.3))
        if K.random() < 1 / 3:
            sx = -sx
        ident = f"instanced-{next(groups)}"
        return (f'<shape type="shapegroup" id="{ident}">{body}</shape>'
                f'<shape type="instance"><ref id="{ident}"/><transform name="to_world">'
                f'<scale x="{f(sx)}" y="{f(sy)}" z="{f(sz)}"/><rotate y="1" angle="{f(K.uniform(-40, 40))}"/>'
                f'</transform></shape>')

    text = re.sub(r'<shape type="(\w+)">(?:(?!</shape>).)*</shape>', instanced, text)
    for spd, body in spd_files:
        with open(os.path.join(os.path.dirname(os.path.abspath(args.out)), spd), "w") as fh:
            fh.write("# wavelength (nm) value\n" + body)
if args.curves and args.scale == 1.0:
    # Strands of Mitsuba's round curves (session 75), from a stream of their own after everything else
    # is drawn (the rest of the scene is the seed's scene without --curves): walks above the floor that
    # keep most of their heading from step to step, each point's radius within 30% of its strand's,
    # thin beside a step, written next to the scene; a BSDF that does not refract (light leaves a curve
    # unbent, its inside culled); half of them turned about y by their to_world (which moves the points,
    # not the radii). Tame strands, as hair is: where a B-spline strand folds over itself (a radius
    # beyond its bend, a cusp), Mitsuba's Embree and caustica's mesh differ (README "Not done").
    C = random.Random(args.seed * 6151 + 41)
    strands = []
    for i in range(C.randint(1, 3)):
        kind = C.choice(["linearcurve", "bsplinecurve"])
        lines = []
        for _ in range(C.randint(1, 4)):
            n = C.randint(4, 9) if kind == "bsplinecurve" else C.randint(2, 7)
            p = [C.uniform(-1.2, 1.2), C.uniform(0.1, 0.8), C.uniform(-0.9, 0.9)]
            step = C.uniform(0.2, 0.4)
            r0 = step * C.uniform(0.05, 0.25)
            heading = [C.uniform(-1, 1), C.uniform(0, 1), C.uniform(-1, 1)]
            for _ in range(n):
                lines.append(" ".join(f(v) for v in p) + " " + f(r0 * C.uniform(0.7, 1.3)))
                heading = [h + C.uniform(-0.6, 0.6) for h in heading]
                norm = max(1e-6, sum(h * h for h in heading) ** 0.5)
                heading = [h / norm for h in heading]
                p = [p[0] + step * heading[0], min(1.5, max(0.05, p[1] + step * heading[1])), p[2] + step * heading[2]]
            lines.append("")
        name = f"{os.path.splitext(os.path.basename(args.out))[0]}-curves-{i}.txt"
        with open(os.path.join(os.path.dirname(os.path.abspath(args.out)), name), "w") as fh:
            fh.write("\n".join(lines))
        saved, R = R, C
        m = bsdf(allow_glass=False)
        R = saved
        turn = (f'<transform name="to_world"><rotate y="1" angle="{f(C.uniform(-60, 60))}"/></transform>'
                if C.random() < 0.5 else "")
        strands.append(f'<shape type="{kind}"><string name="filename" value="{name}"/>{turn}{m}</shape>')
    text = text.replace("</scene>", "".join(strands) + "\n</scene>", 1)
# Mitsuba's path integrator stops shadow rays at a mask's holes and a thin pane, and counts crossing
# them as a bounce; its volpath (the same without media) lets light straight through them by their
# transmittance, as no bounce, as caustica does: the reference for such scenes.
if 'type="mask"' in text or 'type="thindielectric"' in text:
    text = text.replace('<integrator type="path">', '<integrator type="volpath">', 1)
if args.fog:
    # A camera in fog (session 77), from a stream of its own: the sensor's medium, nested or a <ref> to
    # a top-level one written before the sensor, under volpath. Paths keep it past every shape without
    # media and lose it where they leave a glass shape whose exterior is none (Mitsuba's volpath, and
    # caustica's import). Meant with --area-lights: light sampled from points ever nearer a point light
    # inside a medium has no finite variance.
    if args.scale != 1.0:
        raise SystemExit("random_scene.py: --fog is not scaled by --scale")
    G = random.Random(args.seed * 6151 + 29)
    phase = G.choice(["", '<phase type="isotropic"/>',
                      f'<phase type="hg"><float name="g" value="{f(G.uniform(-0.6, 0.8))}"/></phase>'])
    props = (f'<float name="sigma_t" value="{f(G.uniform(0.05, 0.3))}"/>'
             f'<rgb name="albedo" value="{", ".join(f(G.uniform(0.4, 1.0)) for _ in range(3))}"/>{phase}')
    if G.random() < 0.5:
        text = re.sub(r'(<sensor type="\w+">)', lambda m: m.group(1) + f'<medium type="homogeneous">{props}</medium>',
                      text, count=1)
    else:
        text = re.sub(r'(<sensor type="\w+">)', lambda m: f'<medium type="homogeneous" id="fog">{props}</medium>'
                      + m.group(1) + '<ref id="fog"/>', text, count=1)
    text = re.sub(r'(<integrator type=")path(")', r"\1volpath\2", text, count=1)
    # An envmap becomes a constant sky of its scale: in a fog that fills space the sky's light reaches
    # a point only by light sampling, MIS-weighted against a phase or BSDF sample that never gets out,
    # so that light depends on the sampling density, which for an envmap differs from Mitsuba's (README,
    # "Not done"); a constant sky's is uniform in both.
    text = re.sub(r'<emitter type="envmap">(?:(?!</emitter>).)*?<float name="scale" value="([^"]*)"/>(?:(?!</emitter>).)*</emitter>',
                  lambda m: f'<emitter type="constant"><rgb name="radiance" value="{m.group(1)}, {m.group(1)}, {m.group(1)}"/></emitter>',
                  text)
    text = re.sub(r'<emitter type="envmap">(?:(?!</emitter>).)*</emitter>',
                  '<emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>', text)
if args.scale != 1.0:
    text = scale_scene(text, args.scale, os.path.dirname(os.path.abspath(args.out)))
if args.exporter:
    # The same scene as exporters and converters write it, from a stream of its own, each change half
    # the time: a `name` label on every nested object (Blender's add-on; Mitsuba gathers nested objects
    # by kind), booleans spelled "True"/"FALSE", each top-level BSDF, texture or medium referred to
    # through an <alias>, and
    # the camera mirrored by a <scale x="-1"/> before its to_world (the image mirrored in both renderers);
    # below, from another stream, what Mitsuba's lenient XML reader takes.
    E = random.Random(args.seed * 8831 + 97)
    if E.random() < 0.5:
        count = iter(range(10**6))
        text = re.sub(r'<(bsdf|emitter|film|sampler|rfilter) type=',
                      lambda m: f'<{m.group(1)} name="{m.group(1)}_{next(count)}" type=', text)
    if E.random() < 0.5:
        text = re.sub(r'(<boolean name="[^"]+" value=")true"', r'\1True"', text)
        text = re.sub(r'(<boolean name="[^"]+" value=")false"', r'\1FALSE"', text)
    if E.random() < 0.5:
        for ident in re.findall(r'<(?:bsdf|texture|medium) type="\w+" id="([^"]+)"', text):
            text = re.sub(rf'(<ref[^>]*) id="{re.escape(ident)}"', rf'\1 id="{ident}-alias"', text)
            text = text.replace('</scene>', f'<alias id="{ident}" as="{ident}-alias"/>\n</scene>', 1)
    if E.random() < 0.5:
        text = re.sub(r'(<sensor type="\w+">(?:(?!</sensor>).)*?<transform name="to_world">)', r'\1<scale x="-1"/>',
                      text, count=1, flags=re.S)
if args.exporter:
    # What Mitsuba's XML reader takes and strict XML refuses (session 69), from a stream of its own, each
    # half the time: decorative comments with runs of dashes, a declaration after a blank line, and the
    # ids of top-level objects with a bare `&` in them (and in every <ref> to them).
    L = random.Random(args.seed * 7127 + 53)
    if L.random() < 0.5:
        text = re.sub(r"(<shape )", lambda m: "<!-- ---- shape -- of the scene --->" + m.group(1), text, count=3)
    if L.random() < 0.5:
        for ident in re.findall(r'<(?:bsdf|texture|medium) type="\w+" id="([^"&]+)"', text):
            text = text.replace(f'id="{ident}"', f'id="{ident} & co"')
    if L.random() < 0.5:
        text = '\n<?xml version="1.0" encoding="utf-8"?>\n' + text
with open(args.out, "w") as fh:
    fh.write(text)
