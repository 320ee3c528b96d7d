"""What float32 shading would buy: the shading kernels that dominate a preview, timed in float64 and float32.

pyrt shades in float64 (hit points are rebuilt in float64 for robust ray offsets; BSDFs, lights and estimators
follow). The kernels in ``shaders/`` are dtype-generic: given float32 arrays they compute in float32. This tool
times a few of the kernels that a textured, glossy preview spends its time in, on random but valid inputs of one
bounce slice (``--lanes``, the previewer's 24,576 rays by default), both precisions interleaved, ``--rounds``
medians:

- ``gltf_f_cos``: the glTF metallic-roughness BRDF times cos (``shaders.brdfs.gltf_metallic_roughness_f_cos``),
  what every light sample and glossy ray evaluates;
- ``ggx_vndf``: GGX visible-normal sampling (``shaders.microfacet.sample_ggx_vndf``), every glossy ray;
- ``dot_normalize``: a row-wise dot and a normalisation of (N, 3) arrays (``shaders.vec``), everywhere;
- ``bilinear``: a bilinear RGBA texture lookup (``shaders.textures.lookup_bilinear``) into a float32 1024^2 image
  (the texels are float32 in both runs; only the coordinates change precision).

It prints the machine, each kernel's median milliseconds and the float64 / float32 ratio. A kernel's ratio bounds
what float32 gains on its share of a render; the shares come from a profile (``python -m pyinstrument`` on
``pyrt-preview``, docs/preview.md).

Usage: python tools/bench_precision.py [--lanes 24576] [--rounds 15]
"""
from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import numpy as np

from pyrt.shaders import brdfs, microfacet, textures, vec


def _dirs(rng, n):
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2]) + 1e-3
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def kernels(n, seed=0):
    """name -> (float64 call, float32 call): zero-argument closures over the same inputs in each precision."""
    rng = np.random.default_rng(seed)
    wo, wi = _dirs(rng, n), _dirs(rng, n)
    base, met, rough = rng.random((n, 3)), rng.random(n), rng.uniform(0.05, 0.95, n)
    u = rng.random((n, 2))
    uv = rng.random((n, 2)) * 4.0
    image = rng.random((1024, 1024, 4)).astype(np.float32)
    out = {}
    for dt in (np.float64, np.float32):
        a = {k: x.astype(dt) for k, x in dict(wo=wo, wi=wi, base=base, met=met, rough=rough, u=u, uv=uv).items()}
        alpha = microfacet.roughness_to_alpha(a["rough"])
        calls = {
            "gltf_f_cos": lambda a=a: brdfs.gltf_metallic_roughness_f_cos(a["wo"], a["wi"], a["base"], a["met"],
                                                                          a["rough"]),
            "ggx_vndf": lambda a=a, alpha=alpha: microfacet.sample_ggx_vndf(a["wo"], a["u"], alpha),
            "dot_normalize": lambda a=a: (vec.dot(a["wo"], a["wi"]), vec.normalize(a["wo"] + a["wi"])),
            "bilinear": lambda a=a: textures.lookup_bilinear(image, a["uv"]),
        }
        for k, f in calls.items():
            out.setdefault(k, []).append(f)
    return out


def main(argv=None):
    """Command line (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lanes", type=int, default=24576)
    ap.add_argument("--rounds", type=int, default=15)
    args = ap.parse_args(argv)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, numpy {np.__version__}, "
          f"load average {os.getloadavg()[0]:.1f}; {args.lanes} lanes, medians of {args.rounds} interleaved rounds")
    for name, (f64, f32) in kernels(args.lanes).items():
        f64(), f32()                               # warm up
        t64, t32 = [], []
        for _ in range(args.rounds):
            for f, ts in ((f64, t64), (f32, t32)):
                t = time.perf_counter()
                f()
                ts.append(time.perf_counter() - t)
        m64, m32 = statistics.median(t64), statistics.median(t32)
        print(f"{name:14s} float64 {m64 * 1e3:7.2f} ms   float32 {m32 * 1e3:7.2f} ms   ratio {m64 / m32:4.2f}")


if __name__ == "__main__":
    main()
