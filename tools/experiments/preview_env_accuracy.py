"""Accuracy and time of the previewer's environment estimate: the split sum against the sampled estimate.

Renders a model with ``pyrt.apps.preview`` defaults (size and spp from the options), once with every
non-Lambertian material sampled by ``--ref-samples`` BSDF samples per hit (the converged reference of the same
unshadowed estimate: its lookups tend to the map itself as the samples' solid angle shrinks), then with
``preview_method="samples"`` at ``--samples`` per hit and with ``preview_method="split_sum"``; prints render time,
relMSE against the reference and the mean of each. The previewer's studio environment is the map.

With ``--time-rounds N`` it instead times the two estimates at the given size and spp, ``N`` interleaved rounds in
one process (order alternating), and prints the medians of the render phase.

Usage: python tools/experiments/preview_env_accuracy.py MODEL [MODEL ...] [--size 160x120] [--spp 8] [--ref-samples 128]
       python tools/experiments/preview_env_accuracy.py MODEL [MODEL ...] --size 640x480 --spp 4 --time-rounds 3
"""
from __future__ import annotations

import argparse
import statistics

import numpy as np

import pyrt.lights.environment_light as EL
from pyrt.apps.preview import PreviewOptions, render_preview
from pyrt.core.metrics import relmse


def render(path, method, samples, width, height, spp):
    """The preview's linear image (float64) and render time with the environment light's preview settings."""
    original = EL.EnvironmentLight.__init__

    def init(self, *args, **kwargs):
        kwargs.update(preview_method=method, preview_samples=samples)
        original(self, *args, **kwargs)
    EL.EnvironmentLight.__init__ = init
    try:
        r = render_preview(path, PreviewOptions(width=width, height=height, spp=spp))
    finally:
        EL.EnvironmentLight.__init__ = original
    return np.asarray(r.images[0], dtype=np.float64), r.render_time


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("models", nargs="+")
    ap.add_argument("--size", default="160x120")
    ap.add_argument("--spp", type=int, default=8)
    ap.add_argument("--samples", type=int, default=4, help="the sampled estimate's samples per hit (the previewer's)")
    ap.add_argument("--ref-samples", type=int, default=128)
    ap.add_argument("--time-rounds", type=int, default=0, help="time the two estimates instead (interleaved rounds)")
    args = ap.parse_args(argv)
    w, h = (int(x) for x in args.size.split("x"))
    for path in args.models:
        if args.time_rounds:
            times = {"samples": [], "split_sum": []}
            for rnd in range(args.time_rounds):
                for method in (("samples", "split_sum") if rnd % 2 == 0 else ("split_sum", "samples")):
                    times[method].append(render(path, method, args.samples, w, h, args.spp)[1])
            a, b = statistics.median(times["samples"]), statistics.median(times["split_sum"])
            print(f"{path.split('/')[-1]:28s} render medians: samples {a:.2f} s, split_sum {b:.2f} s, "
                  f"ratio {b / a:.3f}  (runs {[round(x, 2) for x in times['samples']]} / "
                  f"{[round(x, 2) for x in times['split_sum']]})", flush=True)
            continue
        ref, _ = render(path, "samples", args.ref_samples, w, h, args.spp)
        for method, k in (("samples", args.samples), ("split_sum", args.samples)):
            img, t = render(path, method, k, w, h, args.spp)
            print(f"{path.split('/')[-1]:28s} {method:9s} render {t:6.2f} s  relMSE {relmse(img, ref):.2e}  "
                  f"mean {img.mean():.4f} (reference {ref.mean():.4f})", flush=True)


if __name__ == "__main__":
    main()
