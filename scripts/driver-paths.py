#!/usr/bin/env python3
"""Judges each driver-specific path on the scene zoo: builds a scratch copy of the tree in which an
environment variable switches one path off where `KernelPlan::for_render` (or the upload) decides
it, then times every zoo scene whose kernel the switch changes, with and without it, alternating.
Prints a line per scene and per path (the zoo's geometric mean counts the other scenes as 1.00x)
and writes CSV. docs/performance.md, "Driver-specific paths on the zoo", is its output.

    scripts/driver-paths.py ZOO_DIR OUT.csv [--runs 5] [--spp 16] [--size 256] [--switches A,B]

It runs on the system's Vulkan driver; VK_ICD_FILENAMES picks another (Mesa 25's lavapipe for the
last three switches, which change nothing on Mesa 22.3).
"""
import argparse, glob, json, math, os, shutil, statistics, subprocess, sys, tempfile

# (file, text, replacement) for each switch: the path is off where the variable is set.
OFF = lambda name: f'std::env::var_os("{name}").is_none()'
SWITCHES = {
    "NO_BAKED": ("crates/veach/src/render.rs",
                 "if cpu_arrays { BakedTriangles::new(",
                 f"if cpu_arrays && {OFF('NO_BAKED')} {{ BakedTriangles::new("),
    # Storage textures, the uniform materials and baked triangles: every array in storage buffers.
    "NO_CPU_ARRAYS": ("crates/veach/src/render.rs",
                      "self.gpu.is_cpu() && !matches!(memory,",
                      f"{OFF('NO_CPU_ARRAYS')} && self.gpu.is_cpu() && !matches!(memory,"),
    "NO_FRAME_COPY": ("crates/veach/src/kernel_plan.rs", "d.frame_copy = adapter.cpu;",
                      f"d.frame_copy = {OFF('NO_FRAME_COPY')} && adapter.cpu;"),
    "NO_STRAIGHT_LINE": ("crates/veach/src/kernel_plan.rs", "straight_line_sample: !wavefront &&",
                         f"straight_line_sample: {OFF('NO_STRAIGHT_LINE')} && !wavefront &&"),
    "NO_CAMERA_LIST": ("crates/veach/src/kernel_plan.rs", "d.camera_list = at_eye &&",
                       f"d.camera_list = {OFF('NO_CAMERA_LIST')} && at_eye &&"),
    "NO_FOOTPRINTS": ("crates/veach/src/kernel_plan.rs", "let apply = runs_of_samples",
                      f"let apply = {OFF('NO_FOOTPRINTS')} && runs_of_samples"),
    # The paths for drivers that branch around code no lane runs (Mesa 25): run with Mesa 25.
    "NO_EMITTER_GRID": ("crates/veach/src/render.rs", "let grid_pays_here = self.gpu.is_cpu() && !masked;",
                        f"let grid_pays_here = {OFF('NO_EMITTER_GRID')} && self.gpu.is_cpu() && !masked;"),
    "NO_BAKED_BOXES": ("crates/veach/src/render.rs", "let group_nodes = if branches {",
                       f"let group_nodes = if branches && {OFF('NO_BAKED_BOXES')} {{"),
    "NO_EMITTER_LIST": ("crates/veach/src/render.rs", "baked.set_emitter_list(branches);",
                        f"baked.set_emitter_list(branches && {OFF('NO_EMITTER_LIST')});"),
}

def build(root):
    scratch = tempfile.mkdtemp(prefix="veach-driver-paths-")
    files = subprocess.check_output(["git", "ls-files", "-z"], cwd=root).decode().split("\0")
    for f in filter(None, files):
        os.makedirs(os.path.join(scratch, os.path.dirname(f)), exist_ok=True)
        shutil.copy2(os.path.join(root, f), os.path.join(scratch, f))
    for name, (path, old, new) in SWITCHES.items():
        p = os.path.join(scratch, path)
        text = open(p).read()
        assert text.count(old) == 1, f"{name}: {old!r} is not in {path} exactly once"
        open(p, "w").write(text.replace(old, new))
    env = dict(os.environ, CARGO_TARGET_DIR=os.path.join(root, "target", "driver-paths"))
    subprocess.run(["cargo", "build", "--release", "-p", "veach-cli"], cwd=scratch, env=env, check=True)
    shutil.rmtree(scratch)
    return os.path.join(env["CARGO_TARGET_DIR"], "release", "veach")

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("zoo"); ap.add_argument("out")
    ap.add_argument("--runs", type=int, default=5); ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--switches", default=",".join(SWITCHES),
                    help="comma-separated switches to time (default: all of them)")
    a = ap.parse_args()
    switches = [x for x in a.switches.split(",") if x]
    unknown = [x for x in switches if x not in SWITCHES]
    if unknown:
        sys.exit(f"unknown switches {unknown}; known: {', '.join(SWITCHES)}")
    root = subprocess.check_output(["git", "rev-parse", "--show-toplevel"]).decode().strip()
    veach = build(root)
    def render(scene, switch):
        env = dict(os.environ)
        if switch: env[switch] = "1"
        stats = os.path.join(tempfile.gettempdir(), "driver-paths.json")
        subprocess.run(["timeout", "-s", "KILL", "600", veach, "render", scene, "-o",
                        os.path.join(tempfile.gettempdir(), "driver-paths.pfm"), "--spp", str(a.spp),
                        "--width", str(a.size), "--height", str(a.size), "--stats", stats],
                       env=env, capture_output=True, check=True)
        d = json.load(open(stats))
        return d["timings_seconds"]["render"], d["kernel"]
    scenes = sorted(glob.glob(os.path.join(a.zoo, "*.gltf")))
    kernels = {s: render(s, None)[1] for s in scenes}
    out = open(a.out, "w"); out.write("path,scene,with_s,without_s,without_over_with\n")
    for switch in switches:
        ratios = []
        for s in scenes:
            if render(s, switch)[1] == kernels[s]:
                continue
            on, off = [], []
            for r in range(a.runs):
                for sw in ((None, switch) if r % 2 == 0 else (switch, None)):
                    (off if sw else on).append(render(s, sw)[0])
            ratio = statistics.median(off) / statistics.median(on)
            ratios.append(ratio)
            name = os.path.basename(s)[:-5]
            out.write(f"{switch},{name},{statistics.median(on):.4f},{statistics.median(off):.4f},{ratio:.3f}\n")
            print(f"{switch} {name}: {ratio:.3f}x without", flush=True)
        mean = math.exp(sum(map(math.log, ratios)) / len(scenes)) if ratios else 1.0
        print(f"{switch}: applies to {len(ratios)} of {len(scenes)} scenes; zoo geometric mean without it {mean:.3f}x", flush=True)

if __name__ == "__main__":
    sys.exit(main())
