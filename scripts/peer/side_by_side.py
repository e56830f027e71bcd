"""Mitsuba's image (left) beside caustica's (right) as one PNG, for the README's import pictures.

    .peer-venv/bin/python scripts/peer/side_by_side.py MITSUBA.exr CAUSTICA.exr OUT.png [--zoom 4] [--gap 4]

Both linear EXRs of the same size; gamma 2.2, clipped to [0, 1], each pixel made a zoom × zoom block
(nearest), so a 96 × 64 test scene is readable, with a white gap between the two. Prints both images'
channel means.
"""
import argparse

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")


def load(path):
    bitmap = mi.Bitmap(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False)
    return np.array(bitmap)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mitsuba")
    ap.add_argument("caustica")
    ap.add_argument("out")
    ap.add_argument("--zoom", type=int, default=4)
    ap.add_argument("--gap", type=int, default=4, help="white pixels between the two (after zooming)")
    a = ap.parse_args()
    left, right = load(a.mitsuba), load(a.caustica)
    if left.shape != right.shape:
        raise SystemExit(f"{a.mitsuba} is {left.shape[1]}×{left.shape[0]}, {a.caustica} {right.shape[1]}×{right.shape[0]}")
    for name, img in [(a.mitsuba, left), (a.caustica, right)]:
        print(name, "channel means", img.mean(axis=(0, 1)))
    def show(img):
        img = np.clip(np.clip(img, 0, None) ** (1 / 2.2) * 255, 0, 255).astype(np.uint8)
        return np.repeat(np.repeat(img, a.zoom, axis=0), a.zoom, axis=1)

    gap = np.full((left.shape[0] * a.zoom, a.gap, 3), 255, dtype=np.uint8)
    row = np.concatenate([show(left), gap, show(right)], axis=1)
    mi.Bitmap(row).write(a.out)
    print("wrote", a.out)


if __name__ == "__main__":
    main()
