"""Independent against padded light and BSDF samples, side by side: ``tools/bench_kinds.py``'s env scene (an
image-textured ground and a rough gold sphere under a procedural sky with a sun, MIS) at the same spp with
``sampler="independent"`` and ``sampler="padded"`` (pyrt.core.sampler), beside a high-spp reference, with each image's
relMSE against it (mean over ``--seeds`` seeds; the picture shows seed 0).

Usage::

    python tools/padded_chart.py [--spp 16] [--size 160x120] [--ref-spp 1024] [--seeds 4]
                                 [--out docs/padded_samples.png]
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _charts import pyplot, save_figure  # noqa: E402  (tools/_charts.py)


def render(sampler, spp, width, height, seed):
    """The env scene's image (H, W, 3) float32 at ``spp`` with ``sampler``."""
    import bench_kinds
    import pyrt
    scene = bench_kinds.make_scene("env", width, height, spp)
    return pyrt.render_full(scene, seed=seed, execution=pyrt.Execution(progress=False),
                            sampling=pyrt.Sampling(sampler=sampler)).image


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--size", default="160x120", help="WIDTHxHEIGHT")
    ap.add_argument("--ref-spp", type=int, default=1024)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--out", default="docs/padded_samples.png")
    args = ap.parse_args(argv)
    import pyrt
    from pyrt.core.metrics import relmse
    w, h = (int(x) for x in args.size.lower().split("x"))
    ref = render("padded", args.ref_spp, w, h, seed=99)
    shown, errors = {}, {}
    for sampler in ("independent", "padded"):
        imgs = [render(sampler, args.spp, w, h, seed) for seed in range(args.seeds)]
        shown[sampler] = imgs[0]
        errors[sampler] = float(np.mean([relmse(im, ref) for im in imgs]))
        print(f"{sampler}: {args.spp} spp, relMSE {errors[sampler]:.3e} (mean of {args.seeds} seeds)")

    def display(img):
        return pyrt.tonemap_to_display(img, tonemap_op="film") ** (1 / 2.2)

    plt = pyplot()
    fig, axes = plt.subplots(2, 3, figsize=(3 * w / 40, 2 * h / 40 + 0.9))
    panels = [(shown["independent"], f"independent, {args.spp} spp\nrelMSE {errors['independent']:.2e} "
               f"({args.seeds} seeds)"),
              (shown["padded"], f"padded, {args.spp} spp\nrelMSE {errors['padded']:.2e} ({args.seeds} seeds)"),
              (ref, f"reference, {args.ref_spp} spp\n{w}x{h}")]
    y0, x0 = int(h * 0.25), int(w * 0.3)          # the gold sphere and its shadow, 2x
    crops = [(img[y0:y0 + h // 2, x0:x0 + w // 2], "") for img, _ in panels]
    for ax, (img, title) in zip(list(axes[0]) + list(axes[1]), panels + crops):
        ax.imshow(np.clip(display(img), 0, 1), interpolation="nearest")
        if title:
            ax.set_title(title, fontsize=8)
        ax.axis("off")
    save_figure(fig, "", args.out)


if __name__ == "__main__":
    main()
