"""Mitsuba's image (left) beside caustica's (right) as one PNG, for the README's import pictures.

    .peer-venv/bin/python scripts/peer/side_by_side.py MITSUBA.exr CAUSTICA.exr [MORE.exr ...] OUT.png [--zoom 4] [--gap 4]

Linear EXRs of the same size, left to right (two or more: the README's other comparisons use it too);
gamma 2.2, clipped to [0, 1], each pixel made a zoom × zoom block (nearest), so a 96 × 64 test scene
is readable, with a white gap between each two. Prints every image's channel means.
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
    ap.add_argument("images", nargs="+", help="two or more EXRs, left to right, then the PNG to write")
    ap.add_argument("--zoom", type=int, default=4)
    ap.add_argument("--gap", type=int, default=4, help="white pixels between two images (after zooming)")
    a = ap.parse_args()
    if len(a.images) < 3:
        raise SystemExit("give two or more EXRs and then the PNG to write")
    paths, a.out = a.images[:-1], a.images[-1]
    imgs = [load(p) for p in paths]
    for p, img in zip(paths, imgs):
        if img.shape != imgs[0].shape:
            raise SystemExit(f"{p} is {img.shape[1]}×{img.shape[0]}, {paths[0]} {imgs[0].shape[1]}×{imgs[0].shape[0]}")
        print(p, "channel means", img.mean(axis=(0, 1)))

    def show(img):
        img = np.clip(np.clip(img, 0, None) ** (1 / 2.2) * 255, 0, 255).astype(np.uint8)
        return np.repeat(np.repeat(img, a.zoom, axis=0), a.zoom, axis=1)

    gap = np.full((imgs[0].shape[0] * a.zoom, a.gap, 3), 255, dtype=np.uint8)
    parts = [show(imgs[0])]
    for img in imgs[1:]:
        parts += [gap, show(img)]
    row = np.concatenate(parts, axis=1)
    mi.Bitmap(row).write(a.out)
    print("wrote", a.out)


if __name__ == "__main__":
    main()
