#!/usr/bin/env python3
"""Writes the vertex-coloured meshes of tests/mitsuba/vertexcolor.xml.

colored-ball.ply  binary little-endian: a UV sphere (radius 1, 24 x 16, smooth normals) whose vertices
                  carry float colours `r`, `g`, `b` that vary smoothly over it (Mitsuba's own kind:
                  `Mesh.write_ply` writes float colours).
colored-tile.ply  ASCII: a 1 x 1 grid of 8 x 8 quads (two triangles each; Mitsuba 3.9.1 reads no ASCII
                  polygons) in z = 0 whose vertices carry 8-bit `red`, `green`,
                  `blue` (a scanner's kind) in stripes and a ramp, so that triangles blend
                  very different colours.

colored-tile16.ply the same tile with 16-bit colours (each 8-bit value times 257), for Mitsuba.
facets.ply        binary little-endian: a flat-shaded ball (12 x 8, triangles) whose faces carry 16-bit
                  `red`, `green`, `blue` (after the index list), neighbouring faces far apart in colour.
prism.ply         ASCII: a hexagonal prism (triangles) whose faces carry float `r`, `g`, `b` given
                  before the index list.

PLY integer colours are sRGB-encoded values: Mitsuba 3.9.1 marks integer properties normalised and
gamma-encoded and decodes 16-bit ones so, but keeps 8-bit ones as 0 to 255 (warning that it expects
[0, 1]); caustica decodes both. vertexcolor.mitsuba.xml, Mitsuba's copy of the scene, reads the tile's
colours from colored-tile16.ply, which both decode to the same values. Run from the repository root:
python3 tests/mitsuba/make-colored.py
"""
import math
import struct


def ball():
    nu, nv = 24, 16
    verts, faces = [], []
    for j in range(nv + 1):
        th = math.pi * j / nv
        for i in range(nu + 1):
            ph = 2 * math.pi * i / nu
            n = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
            c = (0.5 + 0.45 * n[0], 0.5 + 0.45 * n[1] * n[1] - 0.2, 0.15 + 0.8 * (0.5 + 0.5 * math.sin(3 * ph)) * math.sin(th))
            verts.append((n, n, c))
    for j in range(nv):
        for i in range(nu):
            a, b = j * (nu + 1) + i, j * (nu + 1) + i + 1
            c, d = a + nu + 1, b + nu + 1
            if j > 0:
                faces.append((a, b, d))
            if j < nv - 1:
                faces.append((a, d, c))
    head = ("ply\nformat binary_little_endian 1.0\n"
            f"element vertex {len(verts)}\n"
            + "".join(f"property float {k}\n" for k in ["x", "y", "z", "nx", "ny", "nz", "r", "g", "b"])
            + f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    body = b"".join(struct.pack("<9f", *p, *n, *c) for p, n, c in verts)
    body += b"".join(struct.pack("<B3i", 3, *f) for f in faces)
    with open("tests/mitsuba/colored-ball.ply", "wb") as fh:
        fh.write(head.encode() + body)


def tile():
    n = 8
    lines, faces = [], []
    for j in range(n + 1):
        for i in range(n + 1):
            x, y = i / n - 0.5, j / n - 0.5
            r = 230 if (i % 2 == 0) else 20
            g = round(255 * j / n)
            b = 200 if (i + j) % 3 == 0 else 40
            lines.append(f"{x:.6f} {y:.6f} 0 {r} {g} {b}")
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            faces.append(f"3 {a} {a + 1} {a + n + 2}")
            faces.append(f"3 {a} {a + n + 2} {a + n + 1}")
    head = ("ply\nformat ascii 1.0\n"
            f"element vertex {len(lines)}\nproperty float x\nproperty float y\nproperty float z\n"
            "property uchar red\nproperty uchar green\nproperty uchar blue\n"
            f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    with open("tests/mitsuba/colored-tile.ply", "w") as fh:
        fh.write(head + "\n".join(lines + faces))
    # The same values in 16 bits: v / 255 = 257 v / 65535.
    wide = [" ".join(l.split()[:3] + [str(257 * int(c)) for c in l.split()[3:]]) for l in lines]
    with open("tests/mitsuba/colored-tile16.ply", "w") as fh:
        fh.write(head.replace("uchar red", "ushort red").replace("uchar green", "ushort green")
                 .replace("uchar blue", "ushort blue") + "\n".join(wide + faces))


def facets():
    nu, nv = 12, 8
    verts, faces = [], []
    for j in range(nv + 1):
        th = math.pi * j / nv
        for i in range(nu):
            ph = 2 * math.pi * i / nu
            verts.append((math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph)))
    palette = [(60000, 9000, 4000), (3000, 52000, 12000), (8000, 14000, 63000), (61000, 58000, 2000),
               (50000, 3000, 47000), (30000, 30000, 30000), (2000, 48000, 56000)]
    k = 0
    for j in range(nv):
        for i in range(nu):
            a, b = j * nu + i, j * nu + (i + 1) % nu
            c, d = a + nu, b + nu
            for tri in ([a, b, d], [a, d, c]):
                if (j == 0 and tri[0] == a and tri[1] == b) or (j == nv - 1 and tri[1] == d and tri[2] == c):
                    continue  # the triangles that collapse at the poles
                faces.append((tri, palette[k % len(palette)]))
                k += 1
    head = ("ply\nformat binary_little_endian 1.0\n"
            f"element vertex {len(verts)}\n"
            + "".join(f"property float {k}\n" for k in ["x", "y", "z"])
            + f"element face {len(faces)}\nproperty list uchar int vertex_indices\n"
            + "property ushort red\nproperty ushort green\nproperty ushort blue\nend_header\n")
    body = b"".join(struct.pack("<3f", *p) for p in verts)
    body += b"".join(struct.pack("<B3i3H", 3, *t, *c) for t, c in faces)
    with open("tests/mitsuba/facets.ply", "wb") as fh:
        fh.write(head.encode() + body)


def prism():
    n = 6
    verts = []
    for y in (0.0, 1.0):
        for i in range(n):
            ph = 2 * math.pi * (i + 0.5) / n
            verts.append((math.cos(ph), y, math.sin(ph)))
    verts += [(0.0, 0.0, 0.0), (0.0, 1.0, 0.0)]
    faces = []
    for i in range(n):
        a, b = i, (i + 1) % n
        c, d = a + n, b + n
        side = (0.85, 0.2 + 0.12 * i, 0.1) if i % 2 == 0 else (0.1, 0.3, 0.9 - 0.1 * i)
        faces.append((side, (a, d, b)))
        faces.append((side, (a, c, d)))
        faces.append(((0.9, 0.9, 0.2), (2 * n + 1, d, c)))
        faces.append(((0.2, 0.7, 0.3), (2 * n, a, b)))
    head = ("ply\nformat ascii 1.0\n"
            f"element vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\n"
            f"element face {len(faces)}\nproperty float r\nproperty float g\nproperty float b\n"
            "property list uchar int vertex_indices\nend_header\n")
    lines = [f"{x:.6f} {y:.6f} {z:.6f}" for x, y, z in verts]
    lines += [f"{c[0]:.3f} {c[1]:.3f} {c[2]:.3f} 3 {t[0]} {t[1]} {t[2]}" for c, t in faces]
    with open("tests/mitsuba/prism.ply", "w") as fh:
        fh.write(head + "\n".join(lines) + "\n")


ball()
tile()
facets()
prism()
