"""Adaptive renders of the benchmark scenes to Mitsuba llvm's 64- and 256-spp errors: samples, passes, the estimate
and the true error against the target, CPU seconds (one thread).

What chose the pass sizing of :func:`pyrt.render.pass_plan.plan_samples` (docs/rendering.md, the notes of
:mod:`pyrt.render.adaptive`): run it in two checkouts of pyrt, one after the other, several rounds (the samples and
passes are deterministic for a seed; the CPU seconds are not: compare medians of interleaved rounds)::

    python tools/experiments/adaptive_pass_sizing.py --label new
    (cd ../other-checkout && python tools/experiments/adaptive_pass_sizing.py --label old)

The references are pyrt's own fixed-spp renders (two seeds; their noise is taken off), cached in ``--cache``.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir))
import pyrt  # noqa: E402
import _mitsuba_scenes as ms  # noqa: E402
from pyrt.core.metrics import RELMSE_EPS, relmse  # noqa: E402

#: Mitsuba llvm's relMSE at 64 and 256 spp per scene (docs/bench_cpu_error.md, 320 x 240)
TARGETS = {"diffuse": (1.23e-05, 3.48e-06), "shadowed": (8.90e-05, 2.24e-05), "mirror_glass": (2.09e-04, 5.26e-05),
           "sky": (4.26e-03, 1.08e-03), "default": (2.56e-04, 6.06e-05)}
#: the references' spp (their noise below 2 % of the tighter target)
REF_SPP = {"diffuse": 1024, "shadowed": 1024, "mirror_glass": 512, "sky": 512, "default": 512}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--label", default="run")
    ap.add_argument("--scenes", default=",".join(TARGETS))
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--cache", default=os.path.join("out", "adaptive_pass_sizing"))
    ap.add_argument("--min-spp", type=int, default=None, help="the base pass's samples per pixel (default: pyrt's)")
    ap.add_argument("--targets", default="64,256", help="which of Mitsuba's errors to aim at (64, 256)")
    args = ap.parse_args(argv)
    os.makedirs(args.cache, exist_ok=True)
    seeds = [int(s) for s in args.seeds.split(",")]
    base = {} if args.min_spp is None else {"min_spp": args.min_spp}
    for name in args.scenes.split(","):
        scene = ms.SCENES[name][0](os.path.join(args.cache, name))
        prep = pyrt.PreparedScene(scene)
        path = os.path.join(args.cache, f"ref_{name}_{REF_SPP[name]}.npy")
        if not os.path.exists(path):
            ex = pyrt.Execution(prepared=prep, progress=False)
            np.save(path, np.stack([pyrt.render_full(scene, spp=REF_SPP[name], seed=s, execution=ex,
                                                     **ms.PYRT_OPTIONS).image for s in (777, 778)]))
        r1, r2 = np.load(path)
        ref = 0.5 * (r1 + r2)
        noise = float(np.mean((r1 - r2) ** 2 / 4.0 / (ref * ref + RELMSE_EPS)))
        one = pyrt.Execution(prepared=prep, progress=False, threads=1)
        pyrt.render_full(scene, seed=0, sampling=pyrt.Sampling(target_error=1.0), execution=one,
                         **ms.PYRT_OPTIONS)                                  # the kernel's load, not timed
        for target in [t for t, spp in zip(TARGETS[name], (64, 256)) if str(spp) in args.targets.split(",")]:
            rows = []
            for seed in seeds:
                t = time.process_time()
                r = pyrt.render_full(scene, seed=seed, sampling=pyrt.Sampling(target_error=target, time_budget=600,
                                                                              max_spp=4096, **base),
                                     execution=one, **ms.PYRT_OPTIONS)
                rows.append((time.process_time() - t, r.samples_done, r.passes, r.estimated_error,
                             relmse(r.image, ref) - noise))
            cpu, samples, passes, est, true = zip(*rows)
            print(f"{args.label} {name} {target:.2e} samples {np.mean(samples):.0f} passes {list(passes)} "
                  f"est/target {np.mean(est) / target:.2f} true/target {np.mean(true) / target:.2f} "
                  f"(max {max(true) / target:.2f}) cpu {np.median(cpu):.3f} s", flush=True)
        prep.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
