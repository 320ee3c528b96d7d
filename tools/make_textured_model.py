"""Generate a helmet-like textured glTF model for the previewer's speed and memory target (issue 14, item 2).

The target names "a textured model like the 15 k-triangle helmet with five 2048^2 textures" (Khronos'
DamagedHelmet: 14,556 triangles, five 2048 x 2048 JPEGs -- base colour, metallic-roughness, normal,
occlusion, emissive). That file is not on this machine, so this tool writes an equivalent one:

- a closed helmet-like shell (a sphere squashed and dented, with a visor ridge), ~15,000 triangles
  (``--rings`` x ``--segments`` quads), NORMAL and TEXCOORD_0 (the whole atlas wraps once around it,
  so every texel is on the surface and the texture is minified about as much as the helmet's at 640x480);
- five ``--size`` x ``--size`` textures with real detail (multi-octave value noise, panel seams,
  rivets, scratches; deterministic for ``--seed``): ``baseColor`` (sRGB), ``metallicRoughness``
  (G = roughness, B = metallic), ``normal`` (tangent space, from the height field's gradient),
  ``occlusion`` (R), ``emissive`` (sRGB, mostly black with glowing strips), embedded in one ``.glb`` as JPEG
  (``--format jpeg``, like the helmet) or PNG (``--format png``).

Nothing is committed: write it into a temporary folder::

    python tools/make_textured_model.py /tmp/helmet/helmet.glb
    /usr/bin/time -v pyrt-preview /tmp/helmet/helmet.glb -o /tmp/helmet/out.png
"""
from __future__ import annotations

import argparse
import io
import os
import sys

import numpy as np
from PIL import Image

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from pyrt.io.assets import pack_glb  # noqa: E402


def value_noise(shape, cells, rng):
    """Smooth value noise on ``shape = (H, W)``: a ``cells`` x ``cells`` random lattice, bicubic-smoothstep
    interpolated, periodic (tiles seamlessly around the u seam)."""
    h, w = shape
    lattice = rng.random((cells, cells))
    y = np.arange(h) * cells / h
    x = np.arange(w) * cells / w
    y0, x0 = np.floor(y).astype(int), np.floor(x).astype(int)
    fy, fx = y - y0, x - x0
    fy, fx = fy * fy * (3 - 2 * fy), fx * fx * (3 - 2 * fx)
    y1, x1 = (y0 + 1) % cells, (x0 + 1) % cells
    a = lattice[y0][:, x0] * (1 - fx) + lattice[y0][:, x1] * fx
    b = lattice[y1][:, x0] * (1 - fx) + lattice[y1][:, x1] * fx
    return (a * (1 - fy)[:, None] + b * fy[:, None]).astype(np.float32)


def fbm(shape, rng, octaves=7, base_cells=4):
    """Sum of ``octaves`` value-noise octaves (cells doubling, amplitude halving), normalised to [0, 1]."""
    out = np.zeros(shape, dtype=np.float32)
    amp, total = 1.0, 0.0
    for k in range(octaves):
        out += amp * value_noise(shape, base_cells << k, rng)
        total += amp
        amp *= 0.5
    out /= total
    return (out - out.min()) / max(float(out.max() - out.min()), 1e-6)


def texture_set(size, seed):
    """The five texture images (uint8 arrays) of the model: detail at every scale from 1/4 of the
    image down to single texels."""
    rng = np.random.default_rng(seed)
    shape = (size, size)
    n = fbm(shape, rng)
    grain = rng.random(shape, dtype=np.float32)                    # texel-scale grain
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float32) / size
    # panels: a 8 x 6 grid of plates with 3-texel seams, rivets at the plate corners
    px, py = (xx * 8) % 1.0, (yy * 6) % 1.0
    seam = (np.minimum(px, 1 - px) * size / 8 < 1.5) | (np.minimum(py, 1 - py) * size / 6 < 1.5)
    rx, ry = np.minimum(px, 1 - px) * size / 8, np.minimum(py, 1 - py) * size / 6
    rivet = ((rx - 10) ** 2 + (ry - 10) ** 2) < 16
    # scratches: thin random lines
    scratch = np.zeros(shape, dtype=bool)
    for _ in range(60):
        x0, y0 = rng.random(2) * size
        ang = rng.random() * np.pi
        length = 50 + rng.random() * 400
        t = np.linspace(0, length, int(length * 2))
        xs = np.clip((x0 + np.cos(ang) * t).astype(int), 0, size - 1)
        ys = np.clip((y0 + np.sin(ang) * t).astype(int), 0, size - 1)
        scratch[ys, xs] = True
    plate = value_noise(shape, 8, rng)                             # per-region paint tint
    height = 0.6 * n + 0.1 * grain - 0.5 * seam + 0.4 * rivet - 0.2 * scratch

    paint = np.stack([0.55 + 0.3 * plate, 0.45 + 0.2 * n, 0.30 + 0.15 * grain], axis=-1)
    metal = np.array([0.8, 0.8, 0.82], dtype=np.float32)
    worn = (n > 0.62) | scratch
    base = np.where(worn[..., None], metal * (0.7 + 0.3 * grain[..., None]), paint)
    base = base * np.where(seam, 0.35, 1.0)[..., None]
    metallic = np.where(worn | rivet, 1.0, 0.05)
    roughness = np.clip(0.35 + 0.5 * n + 0.15 * grain - 0.3 * scratch, 0.05, 1.0)
    mr = np.stack([np.zeros(shape), roughness, metallic], axis=-1)
    gy, gx = np.gradient(height * 6.0)
    nrm = np.stack([-gx, gy, np.ones(shape)], axis=-1)             # +y = +v (rows grow downward)
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    occ = np.clip(0.55 + 0.45 * n - 0.4 * seam, 0.0, 1.0)
    glow = ((np.abs(yy - 0.45) < 0.01) | (np.abs(xx * 8 % 1.0 - 0.5) < 0.004)) & (n > 0.4)
    emissive = np.where(glow[..., None], np.array([1.0, 0.55, 0.1]) * (0.6 + 0.4 * grain[..., None]), 0.0)

    def u8(a):
        return np.clip(np.rint(np.asarray(a) * 255.0), 0, 255).astype(np.uint8)

    srgb = lambda lin: np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * np.power(np.clip(lin, 0, 1), 1 / 2.4) - 0.055)  # noqa: E731
    return {"baseColor": u8(srgb(base)), "metallicRoughness": u8(mr), "normal": u8(nrm * 0.5 + 0.5),
            "occlusion": u8(np.repeat(occ[..., None], 3, axis=-1)), "emissive": u8(srgb(emissive))}


def helmet_mesh(rings, segments):
    """A closed, dented, squashed sphere with a visor ridge: positions, normals, glTF UVs, triangle indices.

    ``rings`` x ``segments`` quads (2 triangles each, minus the pole fans' degenerate halves); the u seam
    and the poles carry duplicated vertices, as exported meshes do.
    """
    th = np.linspace(0.0, np.pi, rings + 1)                      # polar angle, 0 = top
    ph = np.linspace(0.0, 2 * np.pi, segments + 1)
    T, P = np.meshgrid(th, ph, indexing="ij")
    r = 1.0 + 0.05 * np.cos(6 * P) * np.sin(T) ** 2 + 0.08 * np.exp(-((T - 1.6) / 0.12) ** 2) * (np.cos(P) > 0)
    x = 0.9 * r * np.sin(T) * np.cos(P)
    y = 1.05 * r * np.cos(T)
    z = 0.95 * r * np.sin(T) * np.sin(P)
    pos = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    uv = np.stack([P / (2 * np.pi), T / np.pi], axis=-1).reshape(-1, 2)   # glTF: v down from the top
    idx = np.arange((rings + 1) * (segments + 1)).reshape(rings + 1, segments + 1)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    # counter-clockwise seen from outside (glTF's front faces): x, z = sin(T) (cos P, sin P), y = cos(T) is a
    # left-handed (T, P) chart, so a -> b (+P) -> c (+T) turns counter-clockwise around the outward normal
    tris = np.concatenate([np.stack([a, b, c], 1)[segments:], np.stack([b, d, c], 1)[:-segments]])
    # vertex normals: area-weighted face normals, the seam's duplicates averaged by position
    v = pos[tris]
    fn = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    key = np.unique(np.round(pos, 9), axis=0, return_inverse=True)[1].ravel()
    acc = np.zeros((key.max() + 1, 3))
    for k in range(3):
        np.add.at(acc, key[tris[:, k]], fn)
    nrm = acc[key]
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    return pos.astype(np.float32), nrm.astype(np.float32), uv.astype(np.float32), tris.astype(np.uint32)


def encode(img, fmt, quality):
    """PNG or JPEG bytes of a uint8 (H, W, 3) image."""
    buf = io.BytesIO()
    if fmt == "png":
        Image.fromarray(img).save(buf, format="PNG", compress_level=6)
    else:
        Image.fromarray(img).save(buf, format="JPEG", quality=quality)
    return buf.getvalue()


class GlbWriter:
    """The binary chunk of a GLB being written: buffer views and accessors appended to one buffer."""

    def __init__(self):
        self.chunks, self.views, self.accessors = [], [], []

    def add_view(self, data, target=None):
        """Append ``data`` (bytes, padded to 4) as a buffer view; returns its index."""
        off = sum(len(c) for c in self.chunks)
        self.chunks.append(data + b"\0" * (-len(data) % 4))
        self.views.append({"buffer": 0, "byteOffset": off, "byteLength": len(data),
                           **({"target": target} if target else {})})
        return len(self.views) - 1

    def add_accessor(self, arr, kind, ctype, target):
        """Append ``arr`` as an accessor (glTF ``type`` ``kind``, ``componentType`` ``ctype``); returns its index."""
        acc = {"bufferView": self.add_view(arr.tobytes(), target), "componentType": ctype,
               "count": int(arr.shape[0]), "type": kind}
        if kind == "VEC3" and ctype == 5126:
            acc["min"], acc["max"] = arr.min(0).tolist(), arr.max(0).tolist()
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def mesh_attributes(self, pos, nrm, uv, tris):
        """A primitive's ``attributes`` and ``indices`` for float32 positions, normals, UVs and uint32 triangles."""
        return {"attributes": {"POSITION": self.add_accessor(pos, "VEC3", 5126, 34962),
                               "NORMAL": self.add_accessor(nrm, "VEC3", 5126, 34962),
                               "TEXCOORD_0": self.add_accessor(uv, "VEC2", 5126, 34962)},
                "indices": self.add_accessor(tris.reshape(-1), "SCALAR", 5125, 34963)}

    def write(self, path, header):
        """Write ``header`` (the glTF JSON without accessors, views and buffers) and the chunk to ``path``."""
        header = dict(header, accessors=self.accessors, bufferViews=self.views,
                      buffers=[{"byteLength": sum(len(c) for c in self.chunks)}])
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        with open(path, "wb") as fh:
            fh.write(pack_glb(header, b"".join(self.chunks)))


def make_model(path, *, size=2048, rings=88, segments=88, fmt="jpeg", quality=90, seed=2024):
    """Write the model to ``path`` (.glb); returns (triangle count, {texture: encoded bytes})."""
    pos, nrm, uv, tris = helmet_mesh(rings, segments)
    texs = texture_set(size, seed)
    blobs = {k: encode(v, fmt, quality) for k, v in texs.items()}
    glb = GlbWriter()
    prim = glb.mesh_attributes(pos, nrm, uv, tris)
    mime = "image/png" if fmt == "png" else "image/jpeg"
    names = ["baseColor", "metallicRoughness", "normal", "occlusion", "emissive"]
    images = [{"bufferView": glb.add_view(blobs[k]), "mimeType": mime, "name": k} for k in names]
    tex = {k: {"index": i} for i, k in enumerate(names)}
    header = {
        "asset": {"version": "2.0", "generator": "pyrt tools/make_textured_model.py"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": "helmet"}],
        "meshes": [{"primitives": [dict(prim, material=0)]}],
        "materials": [{"name": "helmet", "pbrMetallicRoughness": {
            "baseColorTexture": tex["baseColor"], "metallicRoughnessTexture": tex["metallicRoughness"]},
            "normalTexture": tex["normal"], "occlusionTexture": tex["occlusion"],
            "emissiveTexture": tex["emissive"], "emissiveFactor": [1.0, 1.0, 1.0]}],
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}],
        "textures": [{"sampler": 0, "source": i} for i in range(len(names))],
        "images": images,
    }
    glb.write(path, header)
    return len(tris), blobs


def main(argv=None):
    """Command line: ``make_textured_model.py OUT.glb [--size 2048] [--format jpeg|png] ...``."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", help="the .glb to write (use a temporary folder: nothing here is committed)")
    ap.add_argument("--size", type=int, default=2048, help="texture width and height (default 2048)")
    ap.add_argument("--rings", type=int, default=88)
    ap.add_argument("--segments", type=int, default=88)
    ap.add_argument("--format", choices=("jpeg", "png"), default="jpeg", help="texture encoding (helmet: jpeg)")
    ap.add_argument("--quality", type=int, default=90, help="JPEG quality")
    ap.add_argument("--seed", type=int, default=2024)
    a = ap.parse_args(argv)
    n, blobs = make_model(a.out, size=a.size, rings=a.rings, segments=a.segments, fmt=a.format,
                          quality=a.quality, seed=a.seed)
    sizes = ", ".join(f"{k} {len(v) / 1e6:.2f} MB" for k, v in blobs.items())
    print(f"{a.out}: {n} triangles, five {a.size}x{a.size} {a.format} textures ({sizes}), "
          f"{os.path.getsize(a.out) / 1e6:.1f} MB")


if __name__ == "__main__":
    main()
