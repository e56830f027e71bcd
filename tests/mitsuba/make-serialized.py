#!/usr/bin/env python3
"""Writes tests/mitsuba/meshes.serialized: two meshes in Mitsuba's serialized format (version 4).

Mesh 0: a once-subdivided icosahedron (42 vertices, 80 faces) on the unit sphere, single precision,
        no normals (the renderer computes them), no texture coordinates.
Mesh 1: a torus (R 0.5, r 0.2, 48 x 24 quads as triangles), double precision, with vertex normals and
        texture coordinates (u around the ring, v around the tube).

Mitsuba renders serialized.xml from it (scripts/mitsuba-refs serialized), so a wrong byte here shows
as an image Mitsuba and caustica disagree on, or as a file Mitsuba refuses. Run from the repository
root: python3 tests/mitsuba/make-serialized.py
"""
import math
import struct
import zlib


def icosphere():
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
         (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    mid = {}

    def midpoint(a, b):
        key = (min(a, b), max(a, b))
        if key not in mid:
            p = [(x + y) / 2 for x, y in zip(v[a], v[b])]
            n = math.sqrt(sum(c * c for c in p))
            v.append(tuple(c / n for c in p))
            mid[key] = len(v) - 1
        return mid[key]

    faces = []
    for a, b, c in f:
        ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
        faces += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
    return v, faces


def torus(R=0.5, r=0.2, nu=48, nv=24):
    pos, nor, uv, faces = [], [], [], []
    for i in range(nu + 1):
        a = 2 * math.pi * i / nu
        for j in range(nv + 1):
            b = 2 * math.pi * j / nv
            n = (math.cos(a) * math.cos(b), math.sin(b), math.sin(a) * math.cos(b))
            pos.append((R * math.cos(a) + r * n[0], r * n[1], R * math.sin(a) + r * n[2]))
            nor.append(n)
            uv.append((i / nu, j / nv))
    for i in range(nu):
        for j in range(nv):
            k, k2 = i * (nv + 1) + j, (i + 1) * (nv + 1) + j
            faces += [(k, k + 1, k2), (k2, k + 1, k2 + 1)]
    return pos, nor, uv, faces


def mesh(name, flags, pos, faces, nor=None, uv=None):
    fmt = 'd' if flags & 0x2000 else 'f'
    body = struct.pack('<I', flags) + name.encode() + b'\0' + struct.pack('<QQ', len(pos), len(faces))
    for arr in [pos] + ([nor] if nor else []) + ([uv] if uv else []):
        body += b''.join(struct.pack('<' + fmt * len(p), *p) for p in arr)
    body += b''.join(struct.pack('<III', *t) for t in faces)
    return struct.pack('<HH', 0x041C, 4) + zlib.compress(body)


v, f = icosphere()
p, n, uv, tf = torus()
parts = [mesh('ball', 0x1000, v, f), mesh('torus', 0x2000 | 0x1 | 0x2, p, tf, n, uv)]
offsets, data = [], b''
for m in parts:
    offsets.append(len(data))
    data += m
data += b''.join(struct.pack('<Q', o) for o in offsets) + struct.pack('<I', len(parts))
open('tests/mitsuba/meshes.serialized', 'wb').write(data)
print(f'wrote tests/mitsuba/meshes.serialized ({len(data)} bytes, {len(parts)} meshes)')
