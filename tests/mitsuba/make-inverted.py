#!/usr/bin/env python3
"""Writes the meshes of tests/mitsuba/inverted.xml from ball.ply (ASCII, smooth normals, 528 faces).

inverted-ball.ply  every vertex normal negated: the normals point against the winding (a mesh exported
                   with its normals turned inward).
mixed-ball.ply     every other face's winding reversed, the normals kept (faces wound inconsistently
                   under consistent normals, as some exporters and scans leave them).

Mitsuba shades a mesh by its vertex normals, whichever way its faces are wound, and gives media by the
winding. Both files are git-ignored: scripts/mitsuba-refs and scripts/random-check run this script,
and tests/mitsuba_import.rs writes the same files (`inverted_meshes`) where they are missing. Run with
any python3: python3 tests/mitsuba/make-inverted.py
"""
import os

here = os.path.dirname(os.path.abspath(__file__))
lines = open(os.path.join(here, "ball.ply")).read().split("\n")
end = lines.index("end_header")
count = next(int(l.split()[2]) for l in lines[:end] if l.startswith("element vertex"))
vertices = lines[end + 1 : end + 1 + count]
faces = lines[end + 1 + count :]

inverted = []
for line in vertices:
    v = line.split()
    v[3:6] = [str(-float(x)) for x in v[3:6]]
    inverted.append(" ".join(v))
open(os.path.join(here, "inverted-ball.ply"), "w").write("\n".join(lines[: end + 1] + inverted + faces))

mixed = []
for k, line in enumerate(faces):
    f = line.split()
    if k % 2 == 1 and len(f) == 4:
        f[2], f[3] = f[3], f[2]
    mixed.append(" ".join(f))
open(os.path.join(here, "mixed-ball.ply"), "w").write("\n".join(lines[: end + 1] + vertices + mixed))
