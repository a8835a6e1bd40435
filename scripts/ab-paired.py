#!/usr/bin/env python3
"""Times two veach builds against each other in paired rounds: each round renders the scene once
with each build, in a random order, and takes the ratio B/A of their render times (`render_gpu`
from --stats: no kernel creation or uploads). Prints the median ratio with a bootstrap 90%
interval, the ratio of the fastest runs, and whether the last images are the same bit for bit.

    cp target/release/veach /tmp/veach-a    # before the change
    cp target/release/veach /tmp/veach-b    # after it
    scripts/ab-paired.py /tmp/veach-a /tmp/veach-b assets/veach-mis.gltf 15 [-- RENDER OPTIONS]
    scripts/ab-paired.py /tmp/veach-a /tmp/veach-b target/zoo 3 [-- RENDER OPTIONS]

Given a folder, it times every .gltf in it, a line per scene, then the geometric means over the
scenes of the paired medians and of fastest/fastest, and the scenes whose images differ.

Why paired: on the 2-core VMs this project is measured on, one build's render time drifts by
±20% over minutes, and a median of alternating runs of the same binary against itself came out
0.89 in one series. A ratio taken within a round cancels the drift that both runs share; the
interval says when the difference is within what is left (two A/A series of 15 rounds gave
0.88-1.08 and 0.93-1.07). The fastest run of each build is a second estimate, less hit by interference,
which only adds time. Render options default to the benchmark setting (MIS 1 + 1, power
heuristic, lights by power, emitters hidden, 16 spp); options after `--` replace them all.
"""
import argparse
import json
import random
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

DEFAULT_OPTIONS = ["--strategy", "mis", "--light-samples", "1", "--brdf-samples", "1", "--heuristic", "power",
                   "--light-selection", "power", "--hide-emitters", "--spp", "16"]


def render_seconds(binary, scene, image, options, work):
    stats = work / "stats.json"
    try:
        p = subprocess.run([binary, "render", scene, "-o", image, *options, "--stats", stats, "--quiet"],
                           capture_output=True, text=True)
    except OSError as e:
        sys.exit(f"cannot run {binary}: {e.strerror}")
    if p.returncode != 0:
        sys.exit(f"{binary} failed on {scene}:\n{p.stderr}")
    return json.loads(stats.read_text())["timings_seconds"]["render_gpu"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("a", help="the build before the change")
    parser.add_argument("b", help="the build after it")
    parser.add_argument("scene", help="a .gltf/.glb, or a folder: every .gltf in it")
    parser.add_argument("rounds", type=int, help="paired rounds (15 or more for a 5%% difference)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the run order and the bootstrap")
    parser.add_argument("options", nargs=argparse.REMAINDER, help="-- then veach render options")
    args = parser.parse_args()
    if args.rounds < 3:
        parser.error("at least 3 rounds")
    options = args.options[1:] if args.options[:1] == ["--"] else args.options
    options = options or DEFAULT_OPTIONS
    rng = random.Random(args.seed)
    scene = Path(args.scene)
    scenes = sorted(scene.glob("*.gltf")) if scene.is_dir() else [scene]
    if not scenes:
        sys.exit(f"no .gltf in {scene}")
    results = [time_scene(args, s, options, rng) for s in scenes]
    if len(results) > 1:
        geomean = statistics.geometric_mean
        print(f"geometric mean over {len(results)} scenes: paired medians {geomean(r[0] for r in results):.3f}, "
              f"fastest/fastest {geomean(r[1] for r in results):.3f}")
        differ = [s.stem for s, r in zip(scenes, results) if not r[2]]
        print("images differ: " + (", ".join(differ) if differ else "none"))


def time_scene(args, scene, options, rng):
    """Paired rounds on one scene: prints them, returns (paired median, fastest ratio, same image)."""
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        images = {"a": work / "a.pfm", "b": work / "b.pfm"}
        times = {"a": [], "b": []}
        ratios = []
        for _ in range(args.rounds):
            order = ["a", "b"]
            rng.shuffle(order)
            t = {w: render_seconds(getattr(args, w), scene, images[w], options, work) for w in order}
            times["a"].append(t["a"])
            times["b"].append(t["b"])
            ratios.append(t["b"] / t["a"])
        same = images["a"].read_bytes() == images["b"].read_bytes()
    boot = sorted(statistics.median(rng.choices(ratios, k=len(ratios))) for _ in range(2000))
    low, high = boot[len(boot) // 20], boot[len(boot) - 1 - len(boot) // 20]
    fastest = min(times["b"]) / min(times["a"])
    print(f"{scene.stem}:")
    for w in "ab":
        print(f"  {w.upper()} median {statistics.median(times[w]):.4f} s, fastest {min(times[w]):.4f} s")
    print(f"  B/A paired median {statistics.median(ratios):.3f} (90% interval {low:.3f}-{high:.3f}), "
          f"fastest/fastest {fastest:.3f}, {args.rounds} rounds")
    print("  images: " + ("the same bit for bit" if same else "differ"), flush=True)
    return statistics.median(ratios), fastest, same


if __name__ == "__main__":
    main()
