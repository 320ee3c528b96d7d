"""Adaptive rendering's base pass: time and true error of ``pyrt.render(target_error=...)`` for several ``min_spp``.

On the Mitsuba benchmark scenes (``tools/_mitsuba_scenes.py``, pyrt side only), each target is the relMSE Mitsuba
``llvm_ad_rgb`` reached at 64 spp in the committed benchmark run (docs/bench_mitsuba.md); the reference is pyrt at
``--ref-spp``. Rounds alternate the order of the ``min_spp`` values; prints every run (wall and process CPU seconds,
true relMSE) and fixed-spp renders for comparison. This measured the default ``min_spp = 4``.

Usage: python tools/experiments/adaptive_base_pass.py [--scenes diffuse,shadowed,default] [--min-spp 2,4,8] [--rounds 2]
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))   # tools/
from _usage import cpu_seconds  # noqa: E402  (tools/_usage.py)

import pyrt
from pyrt.core.metrics import relmse

import _mitsuba_scenes as ms  # noqa: E402  (tools/_mitsuba_scenes.py)

#: llvm_ad_rgb's relMSE at 64 spp in docs/bench_mitsuba.md
TARGETS = {"diffuse": 1.27e-5, "shadowed": 8.94e-5, "mirror_glass": 2.12e-4, "sky": 4.28e-3, "default": 2.55e-4}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="diffuse,shadowed,default")
    ap.add_argument("--min-spp", default="2,4,8")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--ref-spp", type=int, default=256)
    args = ap.parse_args(argv)
    mins = [int(x) for x in args.min_spp.split(",")]
    work = tempfile.mkdtemp(prefix="pyrt_basepass_")
    for name in args.scenes.split(","):
        sc = ms.SCENES[name][0](work)
        prep = pyrt.PreparedScene(sc)
        ref = pyrt.render(sc, spp=args.ref_spp, seed=99, execution=pyrt.Execution(prepared=prep, progress=False),
                          **ms.PYRT_OPTIONS).astype(np.float64)
        for rnd in range(args.rounds):
            for m in (mins if rnd % 2 == 0 else mins[::-1]):
                t, c = time.perf_counter(), cpu_seconds()
                img = pyrt.render(sc, seed=7 + rnd,
                                  sampling=pyrt.Sampling(target_error=TARGETS[name], max_spp=4096, min_spp=m),
                                  execution=pyrt.Execution(prepared=prep, progress=False), **ms.PYRT_OPTIONS)
                print(json.dumps({"scene": name, "min_spp": m, "wall": round(time.perf_counter() - t, 3),
                                  "cpu": round(cpu_seconds() - c, 3), "target": TARGETS[name],
                                  "relmse": relmse(img.astype(np.float64), ref)}), flush=True)
        for spp in (4, 8, 16):
            t, c = time.perf_counter(), cpu_seconds()
            img = pyrt.render(sc, spp=spp, seed=5, execution=pyrt.Execution(prepared=prep, progress=False),
                              **ms.PYRT_OPTIONS)
            print(json.dumps({"scene": name, "fixed_spp": spp, "wall": round(time.perf_counter() - t, 3),
                              "cpu": round(cpu_seconds() - c, 3),
                              "relmse": relmse(img.astype(np.float64), ref)}), flush=True)
        prep.close()


if __name__ == "__main__":
    main()
