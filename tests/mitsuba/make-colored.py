#!/usr/bin/env python3
"""Writes the vertex-coloured meshes of tests/mitsuba/vertexcolor.xml.

colored-ball.ply  binary little-endian: a UV sphere (radius 1, 24 x 16, smooth normals) whose vertices
                  carry float colours `r`, `g`, `b` that vary smoothly over it (Mitsuba's own kind:
                  `Mesh.write_ply` writes float colours).
colored-tile.ply  ASCII: a 1 x 1 grid of 8 x 8 quads (two triangles each; Mitsuba 3.9.1 reads no ASCII
                  polygons) in z = 0 whose vertices carry 8-bit `red`, `green`,
                  `blue` (a scanner's kind) in stripes and a ramp, so that triangles blend
                  very different colours.

Mitsuba 3.9.1 keeps 8-bit colours as 0 to 255 (warning that it expects [0, 1]); caustica scales them
by 1/255, so vertexcolor.mitsuba.xml, Mitsuba's copy of the scene, reads the tile's colours with
`scale` 1/255. Run from the repository root: python3 tests/mitsuba/make-colored.py
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


ball()
tile()
