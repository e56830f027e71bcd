#!/usr/bin/env python3
"""Writes height.png, the bump map of tests/mitsuba/bumpmap.xml: a 48 x 32 (not square) 8-bit grey
PNG of heights in [0, 1] (read raw; 8 bits, as Mitsuba 3.9.1 keeps a 16-bit PNG as half floats): a grid of round bumps, two per 16 texels across and one per 16
down, and a diagonal ridge, so that the gradient turns every way and differs along u and v.
Run from the repository root: python3 tests/mitsuba/make-height.py
"""
import math
import struct
import zlib

W, H = 48, 32


def height(x, y):
    u, v = (x + 0.5) / W, (y + 0.5) / H
    bumps = 0.5 + 0.3 * math.sin(2 * math.pi * 3 * u) * math.cos(2 * math.pi * 2 * v)
    d = (u - v + 1.0) % 1.0 - 0.5
    ridge = 0.2 * math.exp(-(d / 0.08) ** 2)
    return min(1.0, max(0.0, bumps + ridge - 0.1))


def png(path):
    rows = b"".join(b"\x00" + bytes(round(255 * height(x, y)) for x in range(W)) for y in range(H))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", W, H, 8, 0, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b""))


png("tests/mitsuba/height.png")
