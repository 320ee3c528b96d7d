"""docs/tangents.png: a normal map on a low-poly mesh with each triangle's UV tangents against smooth vertex tangents.

An 8-sided cylinder whose UV map is distorted (``u = s + s^2``, ``v = y + sin(2 pi s)``: what unwrapping
tools leave on real models) carries a normal map that tilts every normal the same way along its tangent. Left: the
frame of each triangle's own ``dpdu``, ``dpdv`` (``load_asset(generate_tangents=False)``): it turns at every edge,
and the shading breaks there into facets, although the vertex normals are smooth. Right: the vertex tangents generated from the same UVs (:mod:`pyrt.geometry.tangents`, what glTF
viewers use for files without ``TANGENT``): interpolated, the shading is continuous across the edges (what is left
there is the Mach band of interpolated normals on an 8-gon, in both). Third: 8 x |left - right|, lines along the
edges. The glTF file is written to a temporary folder; the picture is two 320 x 320 renders at 16 spp and their
difference side by side (linear, exposure 0, PBR Neutral tone map).

Usage: python tools/tangent_picture.py [-o docs/tangents.png]
"""
from __future__ import annotations

import argparse
import json
import os
import tempfile

import numpy as np

import pyrt
from pyrt.io.assets import load_asset
from pyrt.io.assets.gltf_write import embedded_gltf


def cylinder(segments=8, distort=1.0):
    """Vertices, faces, outward normals and pyrt (bottom-left) UVs of an open cylinder, radius 1, height 2."""
    s = np.linspace(0.0, 1.0, segments + 1)
    a = 2 * np.pi * s + 2.4          # the UV seam (s = 0 and 1: split vertices, u jumps) turned away from the camera
    ring = np.column_stack([np.cos(a), np.zeros_like(a), -np.sin(a)])
    v = np.concatenate([ring, ring + [0, 2, 0]])
    n = np.concatenate([ring, ring])
    u = s + distort * s * s
    uv = np.concatenate([np.column_stack([u, distort * np.sin(a)]), np.column_stack([u, 2 + distort * np.sin(a)])])
    k = segments + 1
    i = np.arange(segments)
    f = np.concatenate([np.column_stack([i, i + 1, i + 1 + k]), np.column_stack([i, i + 1 + k, i + k])])
    return v, f, n, uv


def tilted(size=8, tilt=(0.8, 0.4)):
    """A tangent-space normal map (uint8) whose every texel is the same normal, tilted by ``tilt`` (x, y) toward the
    tangent and the bitangent: the shading then shows the frame itself."""
    n = np.array([tilt[0], tilt[1], 1.0])
    n /= np.linalg.norm(n)
    return np.tile(np.clip(np.round((n + 1) / 2 * 255), 0, 255).astype(np.uint8), (size, size, 1))


def write_gltf(path, v, f, n, uv, nmap):
    """One normal-mapped primitive, no TANGENT (glTF's top-left UVs)."""
    gl_uv = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]])
    attrs = {"POSITION": v.astype(np.float32), "NORMAL": n.astype(np.float32), "TEXCOORD_0": gl_uv.astype(np.float32)}
    material = {"pbrMetallicRoughness": {"baseColorFactor": [0.75, 0.75, 0.75, 1], "metallicFactor": 0.0,
                                         "roughnessFactor": 0.5},
                "normalTexture": {"index": 0}}
    with open(path, "w") as fh:
        json.dump(embedded_gltf(attrs, f, material, [nmap]), fh)


def render(path, generate):
    cam = pyrt.Camera(position=(2.6, 1.9, 2.9), target=(0, 1.0, 0), fov=42, width=320, height=320, spp=16)
    scene = pyrt.Scene(cam, background=(0.05, 0.05, 0.06))
    load_asset(path, generate_tangents=generate).add_to_scene(scene, lights=False)
    scene.add_light(pyrt.DirectionalLight((-0.5, -0.35, -0.8), irradiance=3.0))
    scene.add_light(pyrt.DirectionalLight((0.7, -0.2, -0.3), irradiance=0.6))
    return pyrt.render(scene, seed=1, execution=pyrt.Execution(progress=False))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default=os.path.join("docs", "tangents.png"))
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "cylinder.gltf")
        write_gltf(path, *cylinder(), tilted())
        left, right = render(path, False), render(path, True)
    gap = np.full((320, 8, 3), 1.0, dtype=np.float32)
    diff = 8.0 * np.abs(left - right)
    pyrt.write_png(args.output, np.concatenate([left, gap, right, gap, diff], axis=1), tonemap="pbr_neutral")
    print(f"wrote {args.output}: mean |left - right| / mean = {np.abs(left - right).mean() / right.mean():.3f}")


if __name__ == "__main__":
    main()
