#!/usr/bin/env python3
"""veach's render settings compared on the scene zoo: efficiency per scene, geometric mean and
worst case.

    target/release/veach generate zoo -o target/zoo --seed 1
    python3 bench/zoo.py target/zoo -o target/zoo-bench --variant "mis 1+1 power=--light-samples 1 --brdf-samples 1 --light-selection power"

For each scene of the folder (`veach generate zoo` writes them, with zoo.csv): a reference
rendered by veach (MIS 4 + 4, one light chosen by power per light sample, --reference-spp, as two
halves of independent seeds whose difference estimates the reference's own relMSE), then
each variant at --spp camera samples per pixel, --seeds times. A variant is NAME=FLAGS: the
flags `veach render` gets on top of the size, seed and --spp ("defaults=" for none at all).
`--variant-binary NAME=PATH` has that variant run another build of veach (a change to the kernel
measured against the build without it; the references come from --veach). Emitters
seen directly are left out of every image (--hide-emitters), so errors measure reflected light.
Times are veach's render times from --stats (kernel creation and uploads excluded).
relMSE = mean over pixels and channels of (x - r)^2 / (r^2 + 1e-2); efficiency = 1 / (relMSE x
seconds), the median over seeds. A render that fails (the driver's loop limit, say) is reported
as such and counts as the worst case.

Writes DIR/zoo.csv (one row per scene and variant, with veach's rays per second: camera, shadow
and direction rays over the render time) and prints a Markdown table: each variant's
efficiency relative to the first variant per scene, then the geometric mean and the worst ratio
over the scenes. A scene enters the means only where the first variant's relMSE is at least 4
times the reference's own (else the ratio measures the reference's noise) and its reference is
not black; the table marks the others.

Needs numpy.
"""

import argparse
import json
import math
import os
import statistics
import subprocess
import sys

import numpy as np


def read_pfm(path):
    with open(path, "rb") as f:
        data = f.read()
    parts = data.split(b"\n", 3)
    w, h = map(int, parts[1].split())
    scale = float(parts[2])
    pixels = np.frombuffer(parts[3][: w * h * 12], dtype="<f4" if scale < 0 else ">f4")
    return pixels.reshape(h, w, 3).astype(np.float64)


def relmse(x, r):
    return float(np.mean((x - r) ** 2 / (r * r + 1e-2)))


def render(veach, scene, out, flags, stats=None):
    cmd = [veach, "render", scene, "-o", out, "--quiet", "--hide-emitters"] + flags
    if stats:
        cmd += ["--stats", stats]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        return p.stderr.strip().splitlines()[-1] if p.stderr.strip() else f"exit {p.returncode}"
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("zoo", help="folder written by `veach generate zoo`")
    ap.add_argument("-o", "--output", default="target/zoo-bench")
    ap.add_argument("--veach", default="target/release/veach")
    ap.add_argument("--width", type=int, default=128)
    ap.add_argument("--height", type=int, default=96)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--reference-spp", type=int, default=256)
    ap.add_argument("--variant", action="append", default=[], metavar="NAME=FLAGS",
                    help="a setting to compare (repeat; the first is the baseline of the ratios)")
    ap.add_argument("--variant-binary", action="append", default=[], metavar="NAME=PATH",
                    help="the veach binary variant NAME runs (default: --veach)")
    ap.add_argument("--scenes", help="comma-separated scene names (default: every scene of zoo.csv)")
    args = ap.parse_args()
    variants = [(v.split("=", 1)[0], v.split("=", 1)[1].split()) for v in args.variant] or [("defaults", [])]
    binaries = dict(b.split("=", 1) for b in args.variant_binary)
    unknown = set(binaries) - {v for v, _ in variants}
    if unknown:
        sys.exit(f"--variant-binary names no --variant: {', '.join(sorted(unknown))}")
    os.makedirs(args.output, exist_ok=True)
    with open(os.path.join(args.zoo, "zoo.csv")) as f:
        names = [line.split(",")[0] for line in f.read().splitlines()[1:]]
    if args.scenes:
        names = [n for n in names if n in args.scenes.split(",")]
    size = ["--width", str(args.width), "--height", str(args.height)]
    rows = []
    for name in names:
        scene = os.path.join(args.zoo, f"{name}.gltf")
        halves = []
        for half, seed in (("a", "999"), ("b", "998")):
            path = os.path.join(args.output, f"{name}-reference-{args.width}x{args.height}-{args.reference_spp}spp-{half}.pfm")
            if not os.path.exists(path):
                err = render(args.veach, scene, path, size + ["--spp", str(max(args.reference_spp // 2, 1)),
                             "--strategy", "mis", "--light-samples", "4", "--brdf-samples", "4",
                             "--light-selection", "power", "--seed", seed])
                if err:
                    print(f"{name}: reference failed: {err}", file=sys.stderr)
                    break
            halves.append(read_pfm(path))
        if len(halves) < 2:
            continue
        ref = 0.5 * (halves[0] + halves[1])
        # Each half's error variance is twice the mean's: E[(a - b)^2] = 4 Var(mean).
        ref_own = relmse(halves[0], halves[1]) / 4.0
        for vname, flags in variants:
            effs, errs, secs, rates = [], [], [], []
            failure = None
            for seed in range(1, args.seeds + 1):
                out = os.path.join(args.output, "image.pfm")
                stats = os.path.join(args.output, "stats.json")
                failure = render(binaries.get(vname, args.veach), scene, out,
                                 size + ["--spp", str(args.spp), "--seed", str(seed)] + flags, stats)
                if failure:
                    break
                with open(stats) as f:
                    st = json.load(f)
                seconds = st["timings_seconds"]["render"]
                rates.append(st["rays_per_second"])
                e = relmse(read_pfm(out), ref)
                errs.append(e)
                secs.append(seconds)
                effs.append(1.0 / max(e * seconds, 1e-300))
            row = {"scene": name, "variant": vname, "failure": failure or "", "reference_relmse": ref_own,
                   "relmse": statistics.median(errs) if errs and not failure else math.nan,
                   "seconds": statistics.median(secs) if secs and not failure else math.nan,
                   "efficiency": statistics.median(effs) if effs and not failure else 0.0,
                   "rays_per_second": statistics.median(rates) if rates and not failure else math.nan}
            rows.append(row)
            print(f"{name:28} {vname:24} relMSE {row['relmse']:.3e} {row['seconds']:.3f} s "
                  f"{row['rays_per_second'] / 1e6:.1f} Mrays/s"
                  + (f"  FAILED: {failure}" if failure else ""), file=sys.stderr, flush=True)
    with open(os.path.join(args.output, "zoo.csv"), "w") as f:
        f.write("scene,variant,relmse,seconds,efficiency,reference_relmse,rays_per_second,failure\n")
        for r in rows:
            f.write(f"{r['scene']},{r['variant']},{r['relmse']:.6e},{r['seconds']:.6f},{r['efficiency']:.6e},"
                    f"{r['reference_relmse']:.6e},{r['rays_per_second']:.6e},\"{r['failure']}\"\n")
    # The table: each variant's efficiency over the first's, per scene.
    base = variants[0][0]
    print(f"| scene | reference's own relMSE | {' | '.join(v for v, _ in variants)} |")
    print("|---|---|" + "---|" * len(variants))
    ratios = {v: [] for v, _ in variants}
    for name in dict.fromkeys(r["scene"] for r in rows):
        by = {r["variant"]: r for r in rows if r["scene"] == name}
        b = by.get(base)
        own = next(iter(by.values()))["reference_relmse"]
        # Ratios only where the baseline's error stands well above the reference's own.
        measurable = b is not None and not b["failure"] and b["relmse"] > 0.0 and b["relmse"] >= 4.0 * own
        black = b is not None and not b["failure"] and b["relmse"] == 0.0
        cells = [f"{own:.1e}" + ("" if measurable else " (black: nothing to rank)" if black else " (too noisy to rank)")]
        for v, _ in variants:
            r = by.get(v)
            if r is None or r["failure"]:
                cells.append("fails")
                if measurable:
                    ratios[v].append(0.0)
            elif not measurable:
                cells.append(f"{r['relmse']:.2e} in {r['seconds']:.3f} s")
            else:
                ratio = r["efficiency"] / b["efficiency"]
                ratios[v].append(ratio)
                cells.append(f"{ratio:.2f}x ({r['relmse']:.2e} in {r['seconds']:.3f} s)" if v != base
                             else f"{r['relmse']:.2e} in {r['seconds']:.3f} s")
        print(f"| {name} | {' | '.join(cells)} |")
    geo = []
    worst = []
    for v, _ in variants:
        good = [x for x in ratios[v] if x > 0]
        geo.append(f"{math.exp(sum(map(math.log, good)) / len(good)):.2f}x" if good else "-")
        worst.append(f"{min(ratios[v]):.2f}x" if ratios[v] else "-")
    n = len(ratios[base])
    print(f"| geometric mean ({n} scenes; failures left out) | | {' | '.join(geo)} |")
    print(f"| worst (a failure: 0.00x) | | {' | '.join(worst)} |")


if __name__ == "__main__":
    main()
