"""Flat, Gouraud and Phong shading side by side (the course's three shading models).

A low-poly icosphere (80 triangles by default) with a glossy Blinn-Phong material under a point
light, rendered three times: flat (one normal per triangle), Gouraud (lighting at the vertices,
radiance interpolated) and Phong (normals interpolated, lighting per pixel). Written as one PNG,
panels left to right in that order, plus the linear EXR.

Usage: python tools/shading_compare.py [--size 256] [--subdivisions 1] [--spp 4] [--out out/shading]
"""
from __future__ import annotations

import argparse
import os

import numpy as np
import trimesh

import pyrt

MODES = ("flat", "gouraud", "phong")


def render_mode(shading, *, size=256, subdivisions=1, spp=4):
    cam = pyrt.Camera(position=(0.0, 0.4, 3.6), target=(0.0, 0.0, 0.0), fov=38, width=size, height=size, spp=spp)
    scene = pyrt.Scene(cam, background=(0.02, 0.02, 0.03), ambient=(0.03, 0.03, 0.03))
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    scene.add_mesh(sphere, pyrt.BlinnPhong(kd=(0.55, 0.12, 0.08), ks=0.35, exponent=60.0), shading=shading,
                   smooth=True, name=f"sphere_{shading}")
    scene.add_plane((0, -1.0, 0), 8.0, pyrt.Lambert(albedo=0.5), name="floor")
    scene.add_light(pyrt.PointLight((2.5, 3.0, 3.0), power_lm=60000.0, temperature=4500))
    return pyrt.render(scene)


def compare(*, size=256, subdivisions=1, spp=4):
    """(size, 3 size, 3) float32: the three renders side by side."""
    return np.concatenate([render_mode(m, size=size, subdivisions=subdivisions, spp=spp) for m in MODES], axis=1)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--subdivisions", type=int, default=1)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--out", default="out/shading")
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    img = compare(size=args.size, subdivisions=args.subdivisions, spp=args.spp)
    png = os.path.join(args.out, "shading_compare.png")
    pyrt.write_png(png, img, tonemap="reinhard")
    pyrt.write_exr(os.path.join(args.out, "shading_compare.exr"), img)
    print(png, "(left to right: " + ", ".join(MODES) + ")")


if __name__ == "__main__":
    main()
