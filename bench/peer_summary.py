#!/usr/bin/env python3
"""One line per scene from bench/peer_mitsuba.py's peer.csv: veach against Mitsuba's best sampler.

    python3 bench/peer_summary.py target/peer-zoo/peer.csv [--spp 16]

At the given sample count (default: the largest in the file), for each scene: veach's median
render time and relMSE against its own reference, and the Mitsuba sampler with the highest
efficiency against Mitsuba's own reference (so that neither renderer is charged for the two
exports' differences), its time and relMSE, and the efficiency ratio veach / Mitsuba, where
efficiency = 1 / (relMSE x seconds). Where the file has several render seeds at that count, the
ratio is followed by its range over the seeds, each seed's renders paired (the same seed's veach
and Mitsuba images, rendered one after the other), so that a scene's timing noise shows. Ends
with the geometric mean and the worst ratio, and how many scenes are below 1x (and how many of
those have every seed below 1x). Prints Markdown (docs/performance.md holds the measured tables).
"""

import argparse
import csv
import math
import statistics
from collections import defaultdict


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv")
    ap.add_argument("--spp", type=int, default=None)
    args = ap.parse_args()

    rows = defaultdict(list)  # (scene, renderer, spp) -> [(seconds, relmse, relmse_own, seed)]
    with open(args.csv) as f:
        for r in csv.DictReader(f):
            key = (r["scene"], r["renderer"], int(r["spp"]))
            rows[key].append((float(r["seconds"]), float(r["relmse"]), float(r["relmse_own_reference"]),
                              int(r["seed"])))
    spp = args.spp or max(k[2] for k in rows)
    scenes = sorted({k[0] for k in rows if k[2] == spp})

    def median_of(scene, renderer, column):
        return statistics.median(v[column] for v in rows[(scene, renderer, spp)])

    print(f"At {spp} spp; Mitsuba with its best sampler per scene, each renderer against its own reference.\n")
    print("| scene | veach s | veach relMSE | Mitsuba s | Mitsuba relMSE | Mitsuba sampler | veach / Mitsuba |")
    print("|---|---|---|---|---|---|---|")
    ratios = []
    for scene in scenes:
        if (scene, "veach", spp) not in rows:
            continue
        vt, vr = median_of(scene, "veach", 0), median_of(scene, "veach", 1)
        best = None
        # The samplers that took this count (peer_mitsuba.py leaves out a count a sampler rounds).
        samplers = {k[1] for k in rows if k[0] == scene and k[2] == spp and k[1].startswith("mitsuba-")}
        for renderer in sorted(samplers):
            mt, mr = median_of(scene, renderer, 0), median_of(scene, renderer, 2)
            if mr > 0 and (best is None or mt * mr < best[0] * best[1]):
                best = (mt, mr, renderer.removeprefix("mitsuba-"))
        if best is None or vr <= 0:
            continue
        ratio = (best[0] * best[1]) / (vt * vr)
        # Each seed's ratio: veach's renders against its own reference (column 1), Mitsuba's
        # against Mitsuba's (column 2), as the medians above.
        veach_by_seed = {v[3]: v[0] * v[1] for v in rows[(scene, "veach", spp)]}
        mitsuba_by_seed = {v[3]: v[0] * v[2] for v in rows[(scene, "mitsuba-" + best[2], spp)]}
        per_seed = [mitsuba_by_seed[k] / veach_by_seed[k] for k in veach_by_seed
                    if k in mitsuba_by_seed and veach_by_seed[k] > 0]
        spread = f" ({min(per_seed):.2f}–{max(per_seed):.2f})" if len(per_seed) >= 3 else ""
        ratios.append((ratio, scene, max(per_seed, default=ratio)))
        print(f"| {scene} | {vt:.3f} | {vr:.2e} | {best[0]:.3f} | {best[1]:.2e} | {best[2]} | {ratio:.2f}×{spread} |")
    if ratios:
        mean = math.exp(sum(math.log(r) for r, _, _ in ratios) / len(ratios))
        worst = min(ratios)
        below = sum(r < 1.0 for r, _, _ in ratios)
        every_seed_below = sum(high < 1.0 for _, _, high in ratios)
        print(f"| **geometric mean ({len(ratios)} scenes)** | | | | | | **{mean:.2f}×** |")
        print(f"\nWorst: {worst[1]} {worst[0]:.2f}×; below 1×: {below} of {len(ratios)}, "
              f"{every_seed_below} of them below 1× at every seed.")


if __name__ == "__main__":
    main()
