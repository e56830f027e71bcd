"""caustica's path tracer against Mitsuba 3 (llvm_ad_rgb) on Mitsuba's own Cornell box, 2 threads each.

Both render the same scene (scenes/mitsuba-cornell.toml is generated from mitsuba.cornell_box()) with
a box pixel filter. A long Mitsuba render is the reference (cached); each renderer is timed at a few
sample counts (three runs each, warm: Mitsuba's JIT compile excluded), scored by RMSE against the
reference, and the two are compared at equal time through RMSE^2 x seconds (constant for Monte Carlo
at a fixed sampler). The means of long renders of both must agree: the benchmark is also an accuracy
check. Prints a Markdown table and writes OUT/peer.json.

Run by scripts/bench-peer, which sets up the virtual environment."""
import argparse
import json
import os
import subprocess
import sys
import time

import drjit as dr
import mitsuba as mi
import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("--caustica", required=True)
ap.add_argument("--scene", required=True)
ap.add_argument("--out", required=True)
ap.add_argument("--ref-spp", type=int, default=4096)
ap.add_argument("--spp", type=int, nargs="+", default=[16, 64, 256])
ap.add_argument("--runs", type=int, default=3)
ap.add_argument("--threads", type=int, default=2)
a = ap.parse_args()
os.makedirs(a.out, exist_ok=True)

mi.set_variant("llvm_ad_rgb")
dr.set_thread_count(a.threads)


def mitsuba_scene(sampler):
    d = mi.cornell_box()
    d["sensor"]["film"]["rfilter"] = {"type": "box"}
    d["sensor"]["sampler"] = {"type": sampler, "sample_count": 4}
    return mi.load_dict(d)


def mitsuba_render(scene, spp, seed):
    t0 = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    arr = np.array(img, dtype=np.float64)  # forces evaluation
    return arr[:, :, :3], time.perf_counter() - t0


def rmse(x, ref):
    return float(np.sqrt(np.mean((x - ref) ** 2)))


# Reference: Mitsuba, independent sampler, in 256-spp chunks with distinct seeds (cached).
ref_path = os.path.join(a.out, f"reference-mitsuba-{a.ref_spp}spp.npy")
if os.path.exists(ref_path):
    ref = np.load(ref_path)
    print(f"reference: {ref_path} (cached)", file=sys.stderr)
else:
    sc = mitsuba_scene("independent")
    chunks = max(1, a.ref_spp // 256)
    acc = None
    t0 = time.perf_counter()
    for k in range(chunks):
        img, _ = mitsuba_render(sc, 256, 10_000 + k)
        acc = img if acc is None else acc + img
        print(f"reference chunk {k + 1}/{chunks}", file=sys.stderr)
    ref = acc / chunks
    np.save(ref_path, ref)
    print(f"reference: {chunks * 256} spp in {time.perf_counter() - t0:.1f} s", file=sys.stderr)

rows = []
# Mitsuba, its default sampler and its low-discrepancy one; the first render of each warms the JIT.
for sampler in ["independent", "ldsampler"]:
    sc = mitsuba_scene(sampler)
    mitsuba_render(sc, 4, 1)
    for spp in a.spp:
        for run in range(a.runs):
            img, t = mitsuba_render(sc, spp, 100 + run)
            rows.append({"renderer": f"mitsuba {mi.__version__} llvm_ad_rgb, {sampler}", "spp": spp, "run": run,
                         "seconds": t, "rmse": rmse(img, ref), "mean": img.reshape(-1, 3).mean(0).tolist()})
            print(rows[-1]["renderer"], spp, f"{t:.2f} s", f"RMSE {rows[-1]['rmse']:.5f}", file=sys.stderr)

# caustica: its render time from the JSON (scene load and BVH excluded, as Mitsuba's load_dict is).
for sampler in ["independent", "sobol", "padded"]:
    for spp in a.spp:
        for run in range(a.runs):
            base = os.path.join(a.out, f"caustica-{sampler}-{spp}-{run}")
            subprocess.run([a.caustica, "render", a.scene, "-q", "-o", base, "--spp", str(spp),
                            "--seed", str(100 + run), "--threads", str(a.threads),
                            "--set", f'render.sampler="{sampler}"'], check=True, stdout=subprocess.DEVNULL)
            stats = json.load(open(base + ".json"))
            img = np.array(mi.Bitmap(base + ".exr"), dtype=np.float64)[:, :, :3]
            t = stats["times_s"]["render"]
            rows.append({"renderer": f"caustica, {sampler}", "spp": spp, "run": run, "seconds": t,
                         "rmse": rmse(img, ref), "mean": img.reshape(-1, 3).mean(0).tolist()})
            print(rows[-1]["renderer"], spp, f"{t:.2f} s", f"RMSE {rows[-1]['rmse']:.5f}", file=sys.stderr)

# Means: caustica at 1024 spp (the image mean of 65,536 pixels is then far inside 0.1%) against the
# reference.
mean_spp = min(a.ref_spp, 1024)
base = os.path.join(a.out, f"caustica-mean-{mean_spp}")
subprocess.run([a.caustica, "render", a.scene, "-q", "-o", base, "--spp", str(mean_spp), "--seed", "7",
                "--threads", str(a.threads)], check=True, stdout=subprocess.DEVNULL)
long_c = np.array(mi.Bitmap(base + ".exr"), dtype=np.float64)[:, :, :3]
mean_c = long_c.reshape(-1, 3).mean(0)
mean_m = ref.reshape(-1, 3).mean(0)

print("| renderer | spp | seconds (min / median / max) | RMSE (median) | RMSE² × s (median) |")
print("|---|---|---|---|---|")
eff = {}
for name in dict.fromkeys(r["renderer"] for r in rows):
    for spp in a.spp:
        rs = [r for r in rows if r["renderer"] == name and r["spp"] == spp]
        ts = sorted(r["seconds"] for r in rs)
        es = sorted(r["rmse"] for r in rs)
        work = sorted(r["rmse"] ** 2 * r["seconds"] for r in rs)
        med = work[len(work) // 2]
        eff.setdefault(name, []).append(med)
        print(f"| {name} | {spp} | {ts[0]:.2f} / {ts[len(ts) // 2]:.2f} / {ts[-1]:.2f} | {es[len(es) // 2]:.5f} | {med:.3e} |")
print()
best_m = min(np.median(v) for k, v in eff.items() if k.startswith("mitsuba"))
for k, v in eff.items():
    if k.startswith("caustica"):
        # Equal-time RMSE ratio = sqrt(work ratio).
        print(f"{k}: equal-time RMSE / best Mitsuba = {np.sqrt(np.median(v) / best_m):.3f}")
ratio = mean_c / mean_m
print(f"channel means, caustica {mean_spp} spp / Mitsuba reference {a.ref_spp} spp: "
      + ", ".join(f"{x:.4f}" for x in ratio))
json.dump({"rows": rows, "mean_ratio": ratio.tolist(), "mean_caustica": mean_c.tolist(),
           "mean_mitsuba": mean_m.tolist()}, open(os.path.join(a.out, "peer.json"), "w"), indent=1)
