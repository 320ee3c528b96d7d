"""How noisy are surfaces lit only by emissive geometry in a preview, and what do more samples buy?

pyrt's emissive surfaces (glTF ``emissiveFactor``, ``KHR_materials_emissive_strength``) are not light sources: a
surface they light receives their light only through the glossy integrator's BSDF-sampled rays (``glossy_samples``
per hit on the first bounce, only for lobes with alpha <= ``glossy_threshold``), so walls next to bright emitters
are grainy at the previewer's 4 spp. This tool renders a model with ``pyrt-preview``'s defaults and with more
samples, two seeds each, interleaved, and reports for each variant the median render time and the estimated
relMSE of one image from the difference of the two seeds (``E[(I1 - I2)^2] / 2`` is the variance of one image):

    relMSE_est = mean over pixels and channels of (I1 - I2)^2 / 2 / (((I1 + I2) / 2)^2 + 0.01)

(pyrt.core.metrics' relMSE with the two-seed mean as the reference, over every pixel of the model), and relMSE x
time, the cost of a given noise level (lower is better). Times are wall-clock seconds of ``render_full`` in this
process; run it on an idle machine, or read the ratios (the variants are interleaved, medians over ``--runs``).

    python tools/emissive_noise.py ../shared/khronos-gltf/EmissiveStrengthTest/EmissiveStrengthTest.glb
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

import pyrt
from pyrt.apps.preview import PreviewOptions, PreviewScene

VARIANTS = {                          # name -> (spp, glossy_samples)
    "default (4 spp, 4 glossy)": (4, 4),
    "4 spp, 16 glossy": (4, 16),
    "16 spp, 4 glossy": (16, 4),
}


def render(ps, spp, glossy_samples, seed):
    """One view of the preview scene ``ps`` (its default azimuth) as ``PreviewScene.render_view`` renders it, with
    ``spp`` and ``glossy_samples``; returns (image, seconds)."""
    o = ps.options
    ps._set_view(ps.azimuth)
    ps.scene.camera.spp = spp
    t0 = time.perf_counter()
    res = pyrt.render_full(ps.scene, seed=seed, max_depth=o.max_depth, progress=False, prepared=ps.prepared,
                           integrator="glossy", glossy_samples=glossy_samples, transparent_shadows=True)
    return res.image, time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("model")
    ap.add_argument("--runs", type=int, default=1, help="timed repetitions of each variant and seed")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    args = ap.parse_args(argv)
    ps = PreviewScene(pyrt.load_asset(args.model), PreviewOptions(width=args.width, height=args.height))
    times = {k: [] for k in VARIANTS}
    images = {k: {} for k in VARIANTS}
    for _ in range(args.runs):
        for seed in (1, 2):
            for name, (spp, gs) in VARIANTS.items():       # interleaved: load drifts hit every variant alike
                img, dt = render(ps, spp, gs, seed)
                times[name].append(dt)
                images[name][seed] = img
    mask = ps.model_mask()          # the camera of the view rendered
    print(f"{os.path.basename(args.model)} at {args.width}x{args.height}, {int(mask.sum())} model pixels, "
          f"load {os.getloadavg()[0]:.1f}, {os.cpu_count()} cores")
    print("| variant | median render s | relMSE (one image, model pixels) | relMSE x s |")
    print("|---|---:|---:|---:|")
    for name in VARIANTS:
        a, b = (images[name][s][mask].astype(np.float64) for s in (1, 2))
        ref = (a + b) / 2
        err = float(np.mean((a - b) ** 2 / 2 / (ref * ref + 0.01)))
        t = statistics.median(times[name])
        print(f"| {name} | {t:.2f} | {err:.4g} | {err * t:.4g} |")
    ps.close()


if __name__ == "__main__":
    main()
