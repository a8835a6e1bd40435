#!/usr/bin/env python3
"""How many direction-ray passes a SIMD group runs per camera sample, with and without direction
rays that wait (shaders/waiting_rays.wgsl, estimate_radiance_waiting; docs/performance.md,
"Direction rays that wait for the lanes beside them").

Each lane takes one camera sample after another (a run of RUN samples per invocation); each sample
has a direction ray with probability p. Without waiting, a group runs a pass for a sample when any
lane has a ray. With waiting, a lane holds one ray; a group runs a pass when some lane would hold
a second or its run ends, and every lane with a ray traces it then (the waiting one first; the new
one at once where the lane held none). With shared slots (experiment/pooled-waiting), a new ray
that finds its lane's slot taken moves to a free lane's slot; a group runs a pass only when the
group's rays outnumber its lanes or a run ends, and then traces a full group of them. With two
slots (experiment/two-slot-waiting), a lane holds up to two rays; a group runs a pass when some
lane would hold a third or a run ends, and each lane traces one ray a pass, its older one first
(at a run's end, every ray it holds).

    scripts/waiting-rays-model.py [--lanes 8] [--run 32] [--trials 4000]
"""
import argparse
import random


def passes_with_shared_slots(p, lanes, run, trials, rng):
    passes = 0
    for _ in range(trials):
        waiting = 0
        for k in range(run):
            fresh = sum(rng.random() < p for _ in range(lanes))
            last = k == run - 1
            if waiting + fresh > lanes or (last and waiting + fresh > 0):
                # Fill the free slots and trace every lane's ray; at the run's end the rays left
                # over take a second pass.
                left = waiting + fresh - lanes
                passes += 1 + (last and left > 0)
                waiting = 0 if last else left
            else:
                waiting += fresh
    return passes / (trials * run)


def passes_at_once(p, lanes, run, trials, rng):
    """Passes per sample where each sample's ray is traced at once: one wherever a lane has one."""
    passes = 0
    for _ in range(trials):
        for _ in range(run):
            passes += any([rng.random() < p for _ in range(lanes)])
    return passes / (trials * run)


def passes_with_slots(p, lanes, run, trials, slots, rng):
    """Passes per sample where each lane holds up to `slots` waiting rays (main's kernel: 1;
    experiment/two-slot-waiting: 2)."""
    passes = 0
    for _ in range(trials):
        held = [0] * lanes
        for k in range(run):
            fresh = [rng.random() < p for _ in range(lanes)]
            if k == run - 1:
                # The run's end: a lane traces everything it holds, one ray a pass.
                passes += max(h + f for h, f in zip(held, fresh))
            elif any(h == slots and f for h, f in zip(held, fresh)):
                passes += 1
                # A lane that held some traced its oldest and now holds the new one too; a lane
                # that held none traced its new one at once.
                held = [h - 1 + f if h > 0 else 0 for h, f in zip(held, fresh)]
            else:
                held = [h + f for h, f in zip(held, fresh)]
    return passes / (trials * run)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lanes", type=int, default=8)
    ap.add_argument("--run", type=int, default=32)
    ap.add_argument("--trials", type=int, default=4000)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    rng = random.Random(args.seed)
    print(f"{args.lanes} lanes, runs of {args.run} samples: passes per camera sample")
    print("| p | each sample's ray at once | waiting | two slots a lane | shared slots |")
    print("|---|---|---|---|---|")
    for p in [0.01, 0.05, 0.1, 0.3, 0.5, 0.8]:
        now = passes_at_once(p, args.lanes, args.run, args.trials, rng)
        wait = passes_with_slots(p, args.lanes, args.run, args.trials, 1, rng)
        two = passes_with_slots(p, args.lanes, args.run, args.trials, 2, rng)
        shared = passes_with_shared_slots(p, args.lanes, args.run, args.trials, rng)
        print(f"| {p} | {now:.3f} | {wait:.3f} | {two:.3f} | {shared:.3f} |")


if __name__ == "__main__":
    main()
