#!/usr/bin/env python3
"""The table scripts/gpu-variants.sh ends with: each variant's render seconds (the light sweep's
scale.csv, the shipped scenes' gpu-rays.csv), and each against the first variant of the same
execution, from the folders that script wrote (OUT/VARIANT-EXECUTION/).

    scripts/gpu-variants-table.py target/gpu-variants built-in wavefront-runs ...
"""
import csv
import os
import sys


def rows(path):
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def times(folder):
    """(column name, seconds) for one variant and execution, in a fixed order."""
    out = []
    for r in rows(os.path.join(folder, "scale.csv")):
        if r["sweep"] == "lights":
            out.append((f"grid {r['lights']} lights, {r['strategy']}", float(r["render_s"])))
    for r in rows(os.path.join(folder, "rays", "gpu-rays.csv")):
        out.append((f"{r['scene']} {r['strategy']}", float(r["render_s_median"])))
    return out


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    out, variants = sys.argv[1], sys.argv[2:]
    executions = sorted({d.rsplit("-", 1)[1] for d in os.listdir(out) if "-" in d})
    for execution in executions:
        found = [(v, dict(times(os.path.join(out, f"{v}-{execution}")))) for v in variants]
        found = [(v, t) for v, t in found if t]
        if not found:
            continue
        base_name, base = found[0]
        print(f"\n{execution}: render seconds, and × {base_name}")
        print("| render | " + " | ".join(v for v, _ in found) + " |")
        print("|---|" + "---|" * len(found))
        for name in base:
            cells = []
            for _, t in found:
                s = t.get(name)
                cells.append("" if s is None else f"{s:.4f} ({s / base[name]:.2f}×)" if base[name] > 0 else f"{s:.4f}")
            print(f"| {name} | " + " | ".join(cells) + " |")
        # Issue 9's many-lights ratio: each variant's 10,000-light time over its 1-light time.
        for strategy in ("mis-power 1+1", "light 2"):
            one, many = f"grid 1 lights, {strategy}", f"grid 10000 lights, {strategy}"
            if one in base and many in base:
                ratios = [f"{t[many] / t[one]:.2f}×" if t.get(one) and many in t else "" for _, t in found]
                print(f"| {strategy}, 1 → 10,000 lights | " + " | ".join(ratios) + " |")


if __name__ == "__main__":
    main()
