#!/usr/bin/env python3
"""Compares two renders of the same settings and seed on two adapters (e.g. scripts/gpu-check.sh's
GPU renders against lavapipe's): the same samples, so the images should agree to float rounding,
except where rounding moves a ray across a triangle edge or a sample across a branch.

    scripts/gpu-compare.py A.pfm B.pfm
"""
import struct
import sys


def read_pfm(path):
    with open(path, "rb") as f:
        if f.readline().strip() != b"PF":
            sys.exit(f"{path}: not an RGB PFM")
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = f.read()
    fmt = "<" if scale < 0 else ">"
    return w, h, struct.unpack(f"{fmt}{w * h * 3}f", data[: w * h * 12])


(wa, ha, a), (wb, hb, b) = read_pfm(sys.argv[1]), read_pfm(sys.argv[2])
if (wa, ha) != (wb, hb):
    sys.exit(f"sizes differ: {wa}x{ha} against {wb}x{hb}")
pixels = wa * ha
mean_a, mean_b = sum(a) / len(a), sum(b) / len(b)
diffs = [abs(x - y) for x, y in zip(a, b)]
rms = (sum(d * d for d in diffs) / len(diffs)) ** 0.5
# A pixel differs where any channel differs by more than 1e-4 of the image's mean.
differing = sum(1 for i in range(pixels) if max(diffs[3 * i : 3 * i + 3]) > 1e-4 * mean_a)
print(f"mean {mean_a:.6f} against {mean_b:.6f} (ratio {mean_b / mean_a:.6f})")
print(f"RMS difference {rms:.3g} ({rms / mean_a:.3g} of the mean), largest {max(diffs):.3g}")
print(f"pixels that differ by more than 1e-4 of the mean: {differing} of {pixels} ({differing / pixels:.2%})")
