"""Generate a Sponza-like glTF scene: many materials, each with its own textures, some alpha-masked, ~260 k triangles.

The previewer's speed target is stated for one textured model (the helmet, ``tools/make_textured_model.py``); the
models a new user downloads next are often whole scenes (Khronos' Sponza: 262 k triangles, 25 materials, 69
textures of 1024², alpha-masked plants and chains). None is on this machine, so this tool writes an equivalent one:

- ``--parts`` helmet-like shells (``make_textured_model.helmet_mesh``, ``--rings`` x ``--segments`` quads each) in a
  square grid, each with its own material;
- each material: base colour (sRGB JPEG), metallic-roughness and normal map (PNG) of ``--size``², its own noise
  (``make_textured_model.texture_set`` with the part's seed); every ``--mask-every``-th material is alpha-masked
  (``alphaMode`` MASK: its base colour is an RGBA PNG with round holes, ``alphaCutoff`` 0.5) and double-sided.

Nothing is committed: write it into a temporary folder::

    python tools/make_scene_model.py /tmp/scene/scene.glb
    /usr/bin/time -v pyrt-preview /tmp/scene/scene.glb -o /tmp/scene/out.png
"""
from __future__ import annotations

import argparse
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_textured_model import GlbWriter, encode, helmet_mesh, texture_set  # noqa: E402


def holes(size, seed):
    """A (size, size) uint8 alpha channel: 0 in round holes on a jittered grid, 255 elsewhere."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float32) / size
    cells = 12
    cx, cy = np.floor(xx * cells), np.floor(yy * cells)
    jitter = rng.random((cells, cells, 2)) * 0.4 + 0.3
    dx = xx * cells - cx - jitter[cy.astype(int), cx.astype(int), 0]
    dy = yy * cells - cy - jitter[cy.astype(int), cx.astype(int), 1]
    return np.where(dx * dx + dy * dy < 0.08, 0, 255).astype(np.uint8)


def make_scene(path, *, parts=25, size=1024, rings=72, segments=72, mask_every=5, seed=7):
    """Write the scene to ``path`` (.glb); returns (triangles, materials, textures)."""
    pos, nrm, uv, tris = helmet_mesh(rings, segments)
    glb = GlbWriter()
    # one shared shell (as a scene's parts share their vertex layout); every part a node with its own material
    prim = glb.mesh_attributes(pos, nrm, uv, tris)
    images, materials, meshes, nodes = [], [], [], []
    side = math.ceil(math.sqrt(parts))
    for k in range(parts):
        maps = texture_set(size, seed + k)
        masked = mask_every > 0 and k % mask_every == mask_every - 1
        base = maps["baseColor"]
        if masked:
            base = np.concatenate([base, holes(size, seed + k)[..., None]], axis=-1)
        first = len(images)
        images.append({"bufferView": glb.add_view(encode(base, "png" if masked else "jpeg", 90)),
                       "mimeType": "image/png" if masked else "image/jpeg", "name": f"part{k}_baseColor"})
        for name in ("metallicRoughness", "normal"):
            images.append({"bufferView": glb.add_view(encode(maps[name], "png", 90)), "mimeType": "image/png",
                           "name": f"part{k}_{name}"})
        mat = {"name": f"part{k}", "pbrMetallicRoughness": {"baseColorTexture": {"index": first},
                                                             "metallicRoughnessTexture": {"index": first + 1}},
               "normalTexture": {"index": first + 2}}
        if masked:
            mat.update(alphaMode="MASK", alphaCutoff=0.5, doubleSided=True)
        materials.append(mat)
        meshes.append({"primitives": [dict(prim, material=k)]})
        nodes.append({"mesh": k, "name": f"part{k}", "translation": [2.5 * (k % side), 0.0, 2.5 * (k // side)]})
    header = {
        "asset": {"version": "2.0", "generator": "pyrt tools/make_scene_model.py"},
        "scene": 0, "scenes": [{"nodes": list(range(parts))}], "nodes": nodes, "meshes": meshes,
        "materials": materials,
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}],
        "textures": [{"sampler": 0, "source": i} for i in range(len(images))],
        "images": images,
    }
    glb.write(path, header)
    return parts * len(tris), parts, len(images)


def main(argv=None):
    """Command line: ``make_scene_model.py OUT.glb [--parts 25] [--size 1024] ...``."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", help="the .glb to write (use a temporary folder: nothing here is committed)")
    ap.add_argument("--parts", type=int, default=25, help="parts, each with its own material (default 25)")
    ap.add_argument("--size", type=int, default=1024, help="texture width and height (default 1024)")
    ap.add_argument("--rings", type=int, default=72)
    ap.add_argument("--segments", type=int, default=72)
    ap.add_argument("--mask-every", type=int, default=5, help="every N-th material alpha-masked (0: none)")
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args(argv)
    n_tri, n_mat, n_tex = make_scene(args.out, parts=args.parts, size=args.size, rings=args.rings,
                                     segments=args.segments, mask_every=args.mask_every, seed=args.seed)
    print(f"wrote {args.out}: {n_tri} triangles, {n_mat} materials, {n_tex} textures of {args.size}², "
          f"{os.path.getsize(args.out) / 1e6:.1f} MB")


if __name__ == "__main__":
    main()
