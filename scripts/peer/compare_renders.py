"""Two renderers' images of one scene, each rendered twice with different seeds: do they agree within
their noise? For scripts/random-check.

    .peer-venv/bin/python scripts/peer/compare_renders.py OURS_A.exr OURS_B.exr THEIRS_A.exr THEIRS_B.exr

Prints one line: each channel's mean as ours / theirs with its noise (from the two seeds' difference,
or the sum of the 8x8 blocks' differences where that is larger),
the worst 8x8 block (luminance ratio and z, its difference over the noise the seeds' differences give
there, pooled with the image-wide block noise), and how many blocks differ (more than 5% and |z| > 5).
Ends with `agree` or `DIFFER` (a channel's mean off by more than 0.5% and 5 of its noise, or any block
that differs); the exit status is 0 either way, 2 for unreadable input.
"""
import sys

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
B = 8
LUM = np.array([0.2126, 0.7152, 0.0722])


def load(path):
    bitmap = mi.Bitmap(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False)
    return np.array(bitmap, dtype=np.float64)


def blocks(x):
    h, w, _ = x.shape
    return x[: h // B * B, : w // B * B].reshape(h // B, B, w // B, B, 3).mean(axis=(1, 3))


def main():
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    try:
        c1, c2, m1, m2 = (load(p) for p in sys.argv[1:5])
    except Exception as e:  # noqa: BLE001 (any unreadable file: say which and stop)
        print(f"unreadable: {e}")
        sys.exit(2)
    c, m = (c1 + c2) / 2, (m1 + m2) / 2
    mean_c, mean_m = c.mean(axis=(0, 1)), m.mean(axis=(0, 1))
    # Variance of each average from its two halves: (a - b)^2 / 4. One difference per channel is a
    # single degree of freedom, which can read several times too low (seeds 2193 and 2222 of session 57:
    # 0.03% and 0.16% where eight seeds a side showed 0.15% and 0.5%), so the variance the blocks'
    # own differences add up to (one degree of freedom per block) is taken when it is larger.
    var_mean = ((c1.mean(axis=(0, 1)) - c2.mean(axis=(0, 1))) ** 2 + (m1.mean(axis=(0, 1)) - m2.mean(axis=(0, 1))) ** 2) / 4
    var_b = (blocks(c1) - blocks(c2)) ** 2 / 4 + (blocks(m1) - blocks(m2)) ** 2 / 4
    var_mean = np.maximum(var_mean, var_b.sum(axis=(0, 1)) / var_b[..., 0].size ** 2)
    # A channel black in both renderers' images agrees (a scene whose light neither renderer's path
    # tracer can reach renders black in both).
    both_black = (mean_c == 0) & (mean_m == 0)
    ratio = np.where(both_black, 1.0, mean_c / np.maximum(mean_m, 1e-12))
    noise = np.sqrt(var_mean) / np.maximum(mean_m, 1e-12)
    z = (blocks(c) - blocks(m)) / np.sqrt(np.maximum(var_b, 1e-12) + var_b.mean(axis=(0, 1)) * 0.5)
    zmax = np.abs(z).max(axis=2)
    lum_ratio = (blocks(c) @ LUM) / np.maximum(blocks(m) @ LUM, 1e-9)
    worst = np.unravel_index(np.argmax(zmax), zmax.shape)
    off = int(((np.abs(lum_ratio - 1) > 0.05) & (zmax > 5)).sum())
    mean_off = bool(((np.abs(ratio - 1) > 0.005) & (np.abs(ratio - 1) > 5 * noise)).any())
    verdict = "DIFFER" if mean_off or off else "agree"
    black = " (both black)" if both_black.all() else ""
    print(
        f"means{black} {ratio[0]:.4f} {ratio[1]:.4f} {ratio[2]:.4f} (noise {noise.max():.4f}); worst block "
        f"(row {worst[0]}, col {worst[1]}) {lum_ratio[worst]:.3f}, z {zmax[worst]:.1f}; "
        f"blocks differing {off}/{zmax.size}: {verdict}"
    )


if __name__ == "__main__":
    main()
