"""Renders a Mitsuba XML scene with Mitsuba 3 (llvm_ad_rgb) into a linear EXR: the independent images
caustica's Mitsuba import is tested against (scripts/mitsuba-refs).

usage: render_xml.py SCENE.xml OUT.exr --spp N [--seed S] [-D name=value ...]"""
import argparse

import mitsuba as mi

ap = argparse.ArgumentParser()
ap.add_argument("scene")
ap.add_argument("out")
ap.add_argument("--spp", type=int, required=True)
ap.add_argument("--seed", type=int, default=0)
ap.add_argument("-D", action="append", default=[], help="name=value, as mitsuba -D")
args = ap.parse_args()

mi.set_variant("llvm_ad_rgb")
params = dict(kv.split("=", 1) for kv in args.D)
scene = mi.load_file(args.scene, **params)
# Render in passes of at most 256 spp (memory), averaged.
total, left, acc = 0, args.spp, None
while left > 0:
    n = min(256, left)
    img = mi.render(scene, spp=n, seed=args.seed * 100003 + total)
    acc = img * n if acc is None else acc + img * n
    total += n
    left -= n
mi.Bitmap(acc / total).write(args.out)
print(f"wrote {args.out} ({total} spp)")
