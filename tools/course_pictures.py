"""Pictures of two course techniques: a coloured-glass shadow and the light-probe mappings.

- ``docs/transparent_shadow.png``: a tinted, absorbing glass slab over a floor lit by a point light, rendered
  with ``transparent_shadows=False`` (the Whitted default: glass casts a shadow like an opaque slab) and
  ``True`` (shadow rays pass through, attenuated by the Fresnel transmittance at both interfaces and by
  Beer-Lambert absorption: the shadow is brighter and coloured).
- ``docs/light_probes.png``: the same procedural sky as a lat-long map, an angular map (Debevec light probe)
  and a mirror-ball image, each made by looking up the lat-long sky along the direction of every texel of the
  mapping (``pyrt.shaders.probes`` formulas), tone-mapped for display.

Usage: python tools/course_pictures.py [--out docs]
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

import pyrt
from pyrt.shaders import probes

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _charts import pyplot  # noqa: E402  (tools/_charts.py)


def glass_shadow_scene(width=240, height=160):
    cam = pyrt.Camera(position=(0, 2.2, 3.2), target=(0, 0.2, 0), fov=40, width=width, height=height, spp=4)
    scene = pyrt.Scene(cam, background=(0.02, 0.02, 0.03))
    scene.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=0.7), name="floor")
    glass = pyrt.Glass(ior=1.5, tint=(1.0, 0.85, 0.6), absorption=(0.2, 1.0, 3.0))
    scene.add_box((0, 0.6, 0), (1.0, 0.08, 1.0), glass, name="slab")
    scene.add_box((1.1, 0.6, 0.2), (0.4, 0.08, 0.4), pyrt.Lambert(albedo=0.5), name="opaque")
    scene.add_light(pyrt.PointLight((0.3, 3.0, 0.4), intensity=40.0))
    return scene


def probe_images(size=160):
    """(lat-long, angular, mirror ball) images of the procedural sky, linear radiance."""
    sky = pyrt.LatLongEnvironment(pyrt.procedural_sky(2 * size, size))
    latlong = np.asarray(sky.image, dtype=np.float64)
    out = [latlong]
    u = (np.arange(size) + 0.5) / size
    U, V = np.meshgrid(u, u[::-1])                  # texture v up: row 0 is v = 1
    uv = np.stack([U.ravel(), V.ravel()], axis=1)
    for to_dir in (probes.angular_uv_to_dir, probes.mirror_ball_uv_to_dir):
        d = to_dir(uv)
        inside = np.sum((uv - 0.5) ** 2, axis=1) <= 0.25          # the probe is the disc inscribed in the image
        ok = inside & np.all(np.isfinite(d), axis=1) & (np.linalg.norm(d, axis=1) > 0.5)
        img = np.zeros((uv.shape[0], 3))
        img[ok] = sky.radiance(d[ok])
        out.append(img.reshape(size, size, 3))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="docs")
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    plt = pyplot()
    display = lambda img: pyrt.tonemap_to_display(np.asarray(img, np.float32), tonemap_op="reinhard")  # noqa: E731
    scene = glass_shadow_scene()
    imgs = [pyrt.render(scene, seed=0, integrator=pyrt.Whitted(transparent_shadows=t)) for t in (False, True)]
    _panels(plt, imgs, ("transparent_shadows=False (Whitted)", "transparent_shadows=True"),
            os.path.join(args.out, "transparent_shadow.png"), (8, 2.9), [1, 1])
    _panels(plt, probe_images(), ("lat-long", "angular map (light probe)", "mirror ball"),
            os.path.join(args.out, "light_probes.png"), (9, 2.6), [2, 1, 1])


def _panels(plt, images, titles, path, figsize, ratios):
    """A row of tone-mapped images with titles, written to ``path``."""
    fig, axes = plt.subplots(1, len(images), figsize=figsize, gridspec_kw={"width_ratios": ratios})
    for ax, img, title in zip(axes, images, titles):
        ax.imshow(pyrt.tonemap_to_display(np.asarray(img, np.float32), tonemap_op="reinhard"))
        ax.set_title(title, fontsize=9)
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    print(f"wrote {path}")

if __name__ == "__main__":
    main()
