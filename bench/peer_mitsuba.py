#!/usr/bin/env python3
"""veach against Mitsuba 3 at equal time, on the same CPU, against the same reference.

    python3 bench/peer_mitsuba.py assets/cornell-box.gltf assets/veach-mis.gltf -o target/peer

For each scene: `veach export-mitsuba` writes the same triangles, normals, radiance and camera
as Mitsuba XML/PLY; a reference is rendered by veach (MIS 4+4, every light, --reference-spp; past 32 lights 16+4 with
lights chosen by power);
then veach (MIS, 1 light + 1 BRDF sample per camera sample, one light chosen per shading point by
the light tree (--veach-light-selection), the power heuristic: veach's defaults) and
Mitsuba 3 (`llvm_ad_rgb`, integrator `direct` with emitter_samples = bsdf_samples
= 1, whose MIS weights are the power heuristic with the sample counts: the same estimator) render
at --min-spp, twice that ... --max-spp samples per pixel (powers of two) over --seeds seeds. Emitters seen directly are left
out of every image (both renderers' hide_emitters), so errors measure reflected light, as
`veach bench` does. Times are render times: veach's from its --stats (kernel creation and
uploads excluded), Mitsuba's wall clock around mi.render after one untimed render at the same
sample count (so that its JIT compilation is excluded too). relMSE = mean over pixels and
channels of (x - r)^2 / (r^2 + 1e-2), efficiency = 1 / (relMSE x seconds).

Light samples: by default as `veach render` takes them (`auto`: rectangles by solid angle, round
lights by their bounding cones, other lights by area); `--veach-light-sampling area` samples by
area on the chosen light's triangles, as Mitsuba samples its mesh emitters. Cones are a technique
Mitsuba applies to its analytic `sphere` shapes but not to meshes;
`--mitsuba-spheres` exports those lights as spheres of the same area (`veach export-mitsuba
--round-lights-as-spheres`), so that both renderers sample them by cone (the geometry then
differs by the tessellation: the "relMSE between references" column says by how much).

`--veach-control-variate` adds veach's unshadowed control variate (`veach render
--control-variate`): the same 1 + 1 samples, MIS-weighted the same, plus the light each diffuse
point would get with nothing in the way, in closed form, so that the samples estimate only the
shadowed difference, on the scenes that take it (`veach info` says; the Veach scene's 3,840
emitter triangles are too many, and it is rendered without, said on stderr). Mitsuba has no such
estimator; the tables then compare veach's best estimator with Mitsuba's best configuration, and
say so in their header.

Samplers: veach uses its default, Owen-scrambled Sobol points (--veach-sampler). Mitsuba is run
with each sampler of --mitsuba-samplers (default: `independent`, its default, and `multijitter`,
its best at equal time on these scenes: docs/performance.md), one table each, so that veach is
compared with Mitsuba as a user would configure it, not only with its default.

Where the two BRDFs differ by definition (glTF's Schlick Fresnel and height-correlated Smith
term against Mitsuba's perfect conductor tinted by specular_reflectance and separable Smith
term, on metals), Mitsuba converges to a different image: the script also renders Mitsuba at
--mitsuba-reference-spp (multijitter) and reports the relMSE between the two references, which is
the floor under Mitsuba's error against veach's reference. Each table also gives Mitsuba's error
against its own reference and the efficiency ratio with each renderer against its own reference
(noise only, no floor). On an all-Lambertian scene (the Cornell box) the two references must agree.

Needs: `pip install mitsuba numpy`; Mitsuba's LLVM variants need libLLVM >= 16
(Debian 12: `apt-get install libllvm19`, then DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1).
veach's speed on lavapipe depends on the Mesa release: `scripts/setup-debian.sh --mesa-backports`
installs Mesa 25 on Debian 12 (or point VK_ICD_FILENAMES at its lvp_icd.json); the table's first
line names the driver that ran.
Writes DIR/peer.csv and prints a Markdown table (docs/performance.md holds the measured one).
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

EPSILON = 1e-2


def read_pfm(path):
    with open(path, "rb") as f:
        if f.readline().strip() != b"PF":
            raise ValueError(f"{path}: not a colour PFM")
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.fromfile(f, "<f4" if scale < 0 else ">f4").reshape(h, w, 3)
    return data[::-1].astype(np.float64)  # PFM rows run bottom to top


def relmse(x, r):
    return float(np.mean((x - r) ** 2 / (r * r + EPSILON)))


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(map(str, cmd))} failed:\n{p.stderr}")
    return p


def veach_render(veach, scene, out, width, height, spp, seed, light, brdf, strategy="mis", selection="power",
                 sampler="sobol", heuristic="power", light_sampling="area", control_variate=False):
    stats = out.with_suffix(".json")
    run([veach, "render", scene, "-o", out, "--width", str(width), "--height", str(height), "--spp", str(spp),
         "--seed", str(seed), "--strategy", strategy, "--light-samples", str(light), "--brdf-samples", str(brdf),
         "--light-selection", selection, "--sampler", sampler, "--heuristic", heuristic,
         "--light-sampling", light_sampling, "--hide-emitters", "--stats", stats, "--quiet"]
        + (["--control-variate"] if control_variate else []))
    s = json.loads(stats.read_text())
    veach_render.driver = f"{s['adapter']}, {s.get('driver', 'driver unknown')}"
    return read_pfm(out), s["timings_seconds"]["render"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("-o", "--output", default="target/peer")
    ap.add_argument("--width", type=int, default=256)
    ap.add_argument("--height", type=int, default=256)
    ap.add_argument("--min-spp", type=int, default=1,
                    help="the smallest sample count measured (powers of two from it to --max-spp); several "
                         "--seeds at one count give medians that one run's timing noise does not move")
    ap.add_argument("--max-spp", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--reference-spp", type=int, default=512)
    ap.add_argument("--mitsuba-reference-spp", type=int, default=4096)
    ap.add_argument("--veach", default="target/release/veach")
    ap.add_argument("--veach-sampler", default="sobol", choices=["sobol", "independent"])
    ap.add_argument("--veach-light-selection", default="tree", choices=["power", "bsdf", "uniform", "tree"],
                    help="how veach's timed renders choose their one light (the reference samples each); "
                         "default: veach's own default, the light tree")
    ap.add_argument("--veach-light-sampling", default="auto", choices=["auto", "area", "solid-angle", "cone"],
                    help="how veach's timed renders sample a point or direction on the chosen light: auto "
                         "(veach's default: each light by its shape), area (the same technique as Mitsuba's "
                         "mesh emitters), solid-angle, or cone (spheres by their bounding cone)")
    ap.add_argument("--veach-control-variate", action="store_true",
                    help="veach's timed renders add the unshadowed diffuse light in closed form and sample only "
                         "the difference (veach render --control-variate; at most 32 emitter triangles)")
    ap.add_argument("--mitsuba-spheres", action="store_true",
                    help="export round lights (the Veach scene's spheres) as analytic Mitsuba spheres of the same "
                         "area, which Mitsuba samples by their cones: pair with --veach-light-sampling cone")
    ap.add_argument("--mitsuba-samplers", default="independent,multijitter",
                    help="comma-separated Mitsuba sampler plugins, one table each")
    args = ap.parse_args()

    import drjit as dr
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    # Mitsuba logs to stdout; its warnings (e.g. multijitter rounding the sample count up) would
    # land in the Markdown tables.
    mi.set_log_level(mi.LogLevel.Error)
    samplers = [x.strip() for x in args.mitsuba_samplers.split(",") if x.strip()]

    out_dir = Path(args.output)
    out_dir.mkdir(parents=True, exist_ok=True)
    budgets = [1 << k for k in range(20) if args.min_spp <= (1 << k) <= args.max_spp]
    if not budgets:
        sys.exit(f"no power of two between --min-spp {args.min_spp} and --max-spp {args.max_spp}")
    # The counts each sampler takes as asked: `ldsampler` rounds up to a square power of two (1
    # and 2 to 4, 8 to 16), so its rows at 1, 2 and 8 spp would be 4 and 16 under another label.
    # A count a sampler rounds is left out of its rows and tables.
    takes = {(spp, s) for spp in budgets for s in samplers
             if mi.load_dict({"type": s, "sample_count": spp}).sample_count() == spp}
    rows = []
    skipped = []
    summary = []
    broken = []
    for scene in args.scenes:
        name = Path(scene).stem
        # --veach-control-variate where the scene takes it (`veach info` says; the Veach scene's
        # 3,840 emitter triangles are too many), plain MIS elsewhere, said on stderr.
        control_variate = args.veach_control_variate
        if control_variate:
            info = run([args.veach, "info", scene]).stdout
            refusal = [line.strip() for line in info.splitlines() if line.strip().startswith("control variate: no")]
            if refusal:
                print(f"{name}: {refusal[0]}; veach renders it without", file=sys.stderr)
                control_variate = False
        spheres = "-spheres" if args.mitsuba_spheres else ""
        xml_dir = out_dir / f"{name}-mitsuba{spheres}"
        export = subprocess.run([args.veach, "export-mitsuba", scene, "-o", xml_dir]
                                + (["--round-lights-as-spheres"] if spheres else []), capture_output=True, text=True)
        if export.returncode != 0:
            # A scene Mitsuba cannot take (a material or light the export has no equivalent for)
            # is left out with the exporter's reason; the others go on.
            print(f"{name}: left out: {export.stderr.strip().splitlines()[-1]}", file=sys.stderr)
            skipped.append(name)
            continue
        w, h = args.width, args.height

        # Named by its sampler: a reference cached by an older veach with independent samples has
        # several times the error (Cornell box: its difference from Mitsuba's was 9.9e-6, not 1.1e-6).
        ref_path = out_dir / f"{name}-reference-{w}x{h}-{args.reference_spp}spp-sobol.pfm"
        if not ref_path.exists():
            # Every light sampled up to 32 lights; past that (where each light's own samples would
            # cost rays in proportion to the count) 16 light samples chosen by power, as veach
            # bench's reference does.
            lights = next(int(line.split(":")[1]) for line in run([args.veach, "info", scene]).stdout.splitlines()
                          if line.strip().startswith("lights:"))
            if lights <= 32:
                veach_render(args.veach, scene, ref_path, w, h, args.reference_spp, 0x5eed, 4, 4, selection="each",
                             heuristic="balance")
            else:
                veach_render(args.veach, scene, ref_path, w, h, args.reference_spp, 0x5eed, 16, 4, selection="power",
                             heuristic="balance")
        reference = read_pfm(ref_path)
        if not reference.any():
            # Nothing lights what the camera sees (the stress scene with the camera inside a
            # closed box): no relative error to rank.
            print(f"{name}: left out: its reference is black", file=sys.stderr)
            skipped.append(name)
            continue

        def mitsuba_render(spp, seed, sampler, timed=True):
            m_scene = mi.load_file(str(xml_dir / "scene.xml"), spp=spp, width=w, height=h, sampler=sampler)
            if timed:
                dr.eval(mi.render(m_scene, seed=seed + 1000, spp=spp))  # compile, untimed
                dr.sync_thread()
            t0 = time.perf_counter()
            img = mi.render(m_scene, seed=seed, spp=spp)
            dr.eval(img)
            dr.sync_thread()
            seconds = time.perf_counter() - t0
            return np.array(img, dtype=np.float64)[..., :3], seconds

        m_ref_path = out_dir / f"{name}-mitsuba{spheres}-reference-{args.mitsuba_reference_spp}spp-multijitter.npy"
        if not m_ref_path.exists():
            img, _ = mitsuba_render(args.mitsuba_reference_spp, 7, "multijitter", timed=False)
            np.save(m_ref_path, img)
        m_reference = np.load(m_ref_path)
        floor = relmse(m_reference, reference)

        # Rows: scene, renderer, spp, seed, seconds, relMSE against veach's reference, against its own.
        for spp in budgets:
            for seed in range(1, args.seeds + 1):
                img, seconds = veach_render(args.veach, scene, out_dir / f"{name}-veach.pfm", w, h, spp, seed, 1, 1,
                                            selection=args.veach_light_selection, sampler=args.veach_sampler,
                                            light_sampling=args.veach_light_sampling,
                                            control_variate=control_variate)
                e = relmse(img, reference)
                rows.append((name, "veach", spp, seed, seconds, e, e))
                line = f"{name} spp {spp} seed {seed}: veach {seconds:.3f} s relMSE {e:.3e}"
                for sampler in samplers:
                    if (spp, sampler) not in takes:
                        continue
                    img, seconds = mitsuba_render(spp, seed, sampler)
                    rows.append((name, f"mitsuba-{sampler}", spp, seed, seconds, relmse(img, reference),
                                 relmse(img, m_reference)))
                    line += f", mitsuba {sampler} {seconds:.3f} s relMSE {rows[-1][5]:.3e}"
                print(line, file=sys.stderr)

        def medians(renderer, spp):
            pts = [r for r in rows if r[0] == name and r[1] == renderer and r[2] == spp]
            med = statistics.median
            return (med(r[4] for r in pts), med(r[5] for r in pts), med(1.0 / (r[4] * r[5]) for r in pts),
                    med(r[6] for r in pts), med(1.0 / (r[4] * r[6]) for r in pts))

        # An unbiased estimate's relMSE falls as 1/spp. Where veach's does not fall at all, its
        # images are not the scene's (a throwaway build left in target/release once timed a kernel
        # that drew nothing, at an efficiency of 0.00x): say so rather than print tables of it.
        # The lowest relMSE past the first count is compared, not the last: on a scene of heavy
        # tails one firefly can lift a single count's (zoo lights-100, seed 1: 0.78, 0.33, 0.14,
        # 0.057, then 0.20 at 16 spp). It needs two counts: a run at one count (--min-spp equal to
        # --max-spp) is not checked.
        if len(budgets) > 1 and budgets[-1] >= 8:
            first = medians("veach", budgets[0])[1]
            lowest = min(medians("veach", spp)[1] for spp in budgets[1:])
            if not lowest < 0.25 * first:
                broken.append(f"{name}: veach's relMSE goes from {first:.3e} at {budgets[0]} spp to at best "
                              f"{lowest:.3e} by {budgets[-1]}; it does not converge to the reference: is "
                              f"{args.veach} the build you meant to measure?")

        for sampler in samplers:
            for spp in budgets:
                if (spp, sampler) not in takes:
                    continue
                vt, vr, ve, _, _ = medians("veach", spp)
                mt, mr, me, mr_own, me_own = medians(f"mitsuba-{sampler}", spp)
                summary.append((sampler, name, spp, vt, vr, ve, mt, mr, me, ve / me, mr_own, ve / me_own, floor))

    with open(out_dir / "peer.csv", "w") as f:
        f.write("scene,renderer,spp,seed,seconds,relmse,relmse_own_reference\n")
        for r in rows:
            f.write(",".join(str(v) for v in r) + "\n")
    # lavapipe's speed depends on the Mesa release (22.3 against 25: 1.4-3.3x), so say which ran.
    print(f"veach ({args.veach_sampler} sampler, lights by {args.veach_light_selection}, "
          f"{args.veach_light_sampling} light sampling"
          f"{', unshadowed control variate where the scene takes it' if args.veach_control_variate else ''})"
          f" on {veach_render.driver}; "
          f"Mitsuba {mi.__version__} ({mi.variant()}){', round lights as analytic spheres' if args.mitsuba_spheres else ''}")
    if skipped:
        print(f"\nLeft out (no Mitsuba equivalent in the export, or a black reference): {', '.join(skipped)}")
    for sampler in samplers:
        print(f"\nMitsuba with the `{sampler}` sampler:\n")
        print("| scene | spp | veach s | veach relMSE | veach eff. | Mitsuba s | Mitsuba relMSE | Mitsuba eff. "
              "| veach / Mitsuba eff. | Mitsuba relMSE, own ref. | veach / Mitsuba eff., own refs "
              "| relMSE between references |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for s in summary:
            if s[0] != sampler:
                continue
            print(f"| {s[1]} | {s[2]} | {s[3]:.3f} | {s[4]:.3e} | {s[5]:.3g} | {s[6]:.3f} | {s[7]:.3e} | {s[8]:.3g} "
                  f"| {s[9]:.2f} | {s[10]:.3e} | {s[11]:.2f} | {s[12]:.2e} |")
    for message in broken:
        print(f"error: {message}", file=sys.stderr)
    if broken:
        sys.exit(1)


if __name__ == "__main__":
    main()
