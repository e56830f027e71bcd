"""A random scene's blends and masks as Mitsuba renders them without bias. For scripts/random-check.

    python3 scripts/peer/dither_blends.py IN.xml OUT.xml

Mitsuba 3.9.1 weighs a `blendbsdf` of a delta BSDF and another, or of two BSDFs of different
densities, with biased sampling weights (README, "Random scenes against Mitsuba"); with a weight
texture of 0s and 1s far finer than a pixel it renders the same blend without bias. This writes
IN.xml with every constant `weight` of a `blendbsdf` and `opacity` of a `mask` replaced by such a
texture: a 10000 x 1 PNG holding round(w * 10000) ones spread evenly (`frac-NNNNN.png`, nearest
filtering, repeated 400 times across u and v). The generator's `ball.ply` has no texture coordinates,
so the dithered shapes that use it read `ball-uv.ply` instead (one with a texture of its own is left
as it is): the same vertices and faces with spherical
(u, v). Both files are written next to OUT.xml. caustica renders IN.xml itself: its blends have no
such bias. Prints how many weights it replaced.

A mask over nothing is not fixed by this (Mitsuba drops a path that leaves through the mask's hole
into the void: its alpha channel), so such a scene may still differ.
"""
import math
import os
import re
import struct
import sys
import xml.etree.ElementTree as ET
import zlib

WIDTH = 10000
REPEAT = 400


def png(path, ones):
    """A WIDTH x 1 greyscale PNG with `ones` white texels spread evenly over black."""
    white = {int(j * WIDTH / ones) for j in range(ones)} if ones else set()
    row = b"\x00" + bytes(255 if x in white else 0 for x in range(WIDTH))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    head = struct.pack(">IIBBBBB", WIDTH, 1, 8, 0, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", head) + chunk(b"IDAT", zlib.compress(row)) + chunk(b"IEND", b""))


def ball_with_uv(src, dst):
    """ball.ply (ASCII: x y z nx ny nz per vertex, then faces) with spherical (u, v) per vertex."""
    with open(src) as f:
        lines = f.read().split("\n")
    end = lines.index("end_header")
    header, body = lines[: end + 1], lines[end + 1 :]
    n = next(int(l.split()[2]) for l in header if l.startswith("element vertex"))
    props = [l for l in header if l.startswith("property float")]
    if [p.split()[2] for p in props] != ["x", "y", "z", "nx", "ny", "nz"]:
        sys.exit(f"{src}: expected x y z nx ny nz vertices")
    at = header.index(props[-1]) + 1
    header[at:at] = ["property float u", "property float v"]
    for i in range(n):
        x, y, z = (float(c) for c in body[i].split()[:3])
        r = math.sqrt(x * x + y * y + z * z) or 1.0
        u = (math.atan2(z, x) / (2 * math.pi)) % 1.0
        v = math.acos(max(-1.0, min(1.0, y / r))) / math.pi
        body[i] = f"{body[i]} {u:.6f} {v:.6f}"
    with open(dst, "w") as f:
        f.write("\n".join(header + body))


def lenient(text):
    """What Mitsuba's XML reader takes and Python's refuses, made strict (`random_scene.py --exporter`
    writes each): comments (with runs of dashes) dropped, blank lines before the declaration dropped, a
    bare `&` escaped."""
    text = re.sub(r"<!--.*?-->", "", text, flags=re.S).lstrip()
    return re.sub(r"&(?!(amp|lt|gt|quot|apos|#[0-9]+|#x[0-9a-fA-F]+);)", "&amp;", text)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    src, dst = sys.argv[1:3]
    tree = ET.ElementTree(ET.fromstring(lenient(open(src).read())))
    out_dir = os.path.dirname(os.path.abspath(dst))
    replaced, uses_ball = 0, False
    for shape in tree.iter("shape"):
        here = replaced
        ball = next((s for s in shape.findall("string") if s.get("name") == "filename" and s.get("value") == "ball.ply"), None)
        if ball is not None and shape.find(".//texture") is not None:
            # Texture coordinates would change how its own texture reads (the generator's label.png
            # reads (0, 0) on ball.ply, in both renderers): left as it is.
            continue
        for parent in shape.iter("bsdf"):
            name = {"blendbsdf": "weight", "mask": "opacity"}.get(parent.get("type"))
            if name is None:
                continue
            for i, child in enumerate(list(parent)):
                if child.tag != "float" or child.get("name") != name:
                    continue
                ones = round(min(1.0, max(0.0, float(child.get("value")))) * WIDTH)
                file = f"frac-{ones:05d}.png"
                png(os.path.join(out_dir, file), ones)
                tex = ET.Element("texture", type="bitmap", name=name)
                ET.SubElement(tex, "string", name="filename", value=file)
                ET.SubElement(tex, "string", name="filter_type", value="nearest")
                uv = ET.SubElement(tex, "transform", name="to_uv")
                ET.SubElement(uv, "scale", x=str(REPEAT), y=str(REPEAT))
                parent.remove(child)
                parent.insert(i, tex)
                replaced += 1
        # Only the shapes dithered here read the ball with texture coordinates.
        if ball is not None and replaced > here:
            ball.set("value", "ball-uv.ply")
            uses_ball = True
    if uses_ball:
        ball_with_uv(os.path.join(os.path.dirname(os.path.abspath(src)), "ball.ply"), os.path.join(out_dir, "ball-uv.ply"))
    tree.write(dst)
    print(replaced)


if __name__ == "__main__":
    main()
