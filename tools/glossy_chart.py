"""Roughness sweep of gold with and without glossy reflection rays (``docs/glossy_sweep.png``).

Five gold GGX spheres (``CookTorrance(metal="gold")``, roughness 0, 0.05, 0.1, 0.2, 0.4) stand on a
checkered floor in front of a checkered wall with a coloured panel, lit by a visible rectangular light and a
dim constant sky. Top row: ``integrator="whitted"`` (only delta lobes spawn rays: the spheres show the light
sources and the sky, none of the scene); bottom row: ``integrator="glossy"`` (BSDF-sampled rays at lobes with
``alpha <= 0.4``, MIS with light sampling). The rightmost sphere (roughness 0.4, alpha 0.16) is still traced.

Usage::

    python tools/glossy_chart.py [--out docs/glossy_sweep.png] [--width 360] [--spp 16]
"""
from __future__ import annotations

import argparse
import os
import time


import pyrt
from pyrt.lights import ConstantEnvironment, set_environment
from pyrt.shaders.color import srgb_encode
from _charts import pyplot  # noqa: E402  (tools/_charts.py)

HERE = os.path.dirname(os.path.abspath(__file__))
ROUGHNESS = (0.0, 0.05, 0.1, 0.2, 0.4)


def make_scene(width, height):
    """The sweep scene (camera ``width`` x ``height``)."""
    cam = pyrt.Camera(position=(0, 1.1, 5.2), target=(0, 0.45, 0), fov=30, width=width, height=height)
    sc = pyrt.Scene(cam)
    for i, r in enumerate(ROUGHNESS):
        sc.add_sphere((-2.0 + i, 0.4, 0), 0.4, pyrt.CookTorrance(ks=1.0, roughness=r, metal="gold"),
                      subdivisions=5, name=f"gold_{r}")
    sc.add_plane((0, 0, 0), 12.0, pyrt.Lambert(pyrt.CheckerTexture(0.15, 0.75, scale=12.0)), name="floor")
    sc.add_plane((0, 3, -2.0), 12.0, pyrt.Lambert(pyrt.CheckerTexture((0.1, 0.2, 0.5), 0.8, scale=16.0)),
                 normal=(0, 0, 1), name="wall")
    sc.add_box((1.2, 0.9, -1.6), (1.4, 1.8, 0.05), pyrt.Lambert((0.8, 0.15, 0.1)), name="panel")
    pyrt.RectLight((0, 3.2, 2.0), normal=(0, -1, -0.4), size=(3.0, 1.0), radiance=6.0, n_samples=4,
                   name="softbox").add_to(sc)
    set_environment(sc, ConstantEnvironment(0.15), lighting="map", n_samples=1)
    return sc


def main(argv=None):
    """Render both rows and write the chart."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(HERE, "..", "docs", "glossy_sweep.png"))
    ap.add_argument("--width", type=int, default=360)
    ap.add_argument("--spp", type=int, default=16)
    args = ap.parse_args(argv)
    h = args.width * 3 // 8
    rows = []
    for integ in ("whitted", "glossy"):
        sc = make_scene(args.width, h)
        res = pyrt.render_full(sc, spp=args.spp, seed=1, integrator=integ, execution=pyrt.Execution(progress=False))
        print(f"{integ}: {res.stats.time_total:.1f} s, {res.stats.rays} rays")
        rows.append((integ, srgb_encode(pyrt.tonemap_to_display(res.image, exposure=0.5))))
    plt = pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(args.width / 90, 2 * h / 90 + 0.5), dpi=90)
    for ax, (integ, img) in zip(axes, rows):
        ax.imshow(img)
        ax.set_axis_off()
        ax.set_title(f'integrator="{integ}": roughness ' + " / ".join(f"{r:g}" for r in ROUGHNESS), fontsize=7)
    fig.tight_layout(pad=0.2)
    fig.savefig(args.out)
    print(f"wrote {args.out} ({os.path.getsize(args.out) // 1024} KB)")


if __name__ == "__main__":
    t0 = time.perf_counter()
    main()
    print(f"total {time.perf_counter() - t0:.1f} s")
