"""glTF coverage -> pyrt: ``alphaMode`` / ``alphaCutoff`` / ``doubleSided`` and the coverage alpha
``baseColorFactor.a x baseColorTexture.a x COLOR_0.a`` (glTF 2.0 spec, "Alpha Coverage"), set on the pyrt material
with :meth:`pyrt.materials.Material.set_coverage` (rendered by :mod:`pyrt.integrators.coverage`).

- ``OPAQUE`` (the default): every alpha is ignored, as the spec asks.
- ``MASK``: ``"mask"`` with ``alpha_cutoff = alphaCutoff`` (default 0.5).
- ``BLEND``: ``"blend"`` (straight-through coverage, shadows included; no sorting problem in a ray tracer).
- ``doubleSided`` false (the default): back faces culled for camera and secondary rays.

The alpha channel of the base-colour image (RGBA or grey+alpha; linear, as PNG alpha is) becomes a 1-channel
texture with the base colour's sampler and transform, decoded once per image and shared like the colour
channels (:func:`alpha_texture`).
"""
from __future__ import annotations

import numpy as np

from pyrt.textures import ImageTexture, Texture, footprinted
from pyrt.io.assets.common import PBRParams

#: glTF alphaMode -> pyrt's Material.alpha_mode
ALPHA_MODES = {"OPAQUE": "opaque", "MASK": "mask", "BLEND": "blend"}


def alpha_texture(image, label, slot, cache):
    """The alpha channel of a base-colour image as a 1-channel linear :class:`ImageTexture`, or None.

    Parameters
    ----------
    image : (H, W, C) float ndarray
        The image as stored (:meth:`pyrt.io.assets.gltf_file.GltfFile.image_array`); alpha is channel C - 1
        when C is 2 or 4.
    label : str
        The image as messages name it.
    slot : pyrt.io.assets.common.TextureSlot
        The base-colour slot (its texture's wrap, filter and UV transform are reused).
    cache : dict
        The per-load texel cache, key ``(image index, "linear", "alpha")``.
    """
    img = np.asarray(image)
    c = img.shape[2] if img.ndim == 3 else 1
    if c not in (2, 4):
        return None
    key = (slot.image, "linear", "alpha")
    src = cache.get(key)
    if src is None:
        src = np.ascontiguousarray(img[:, :, c - 1])
    tex = slot.texture
    t = ImageTexture(src, srgb=False, wrap=tex.wrap, filter=tex.filter, scale=tex.scale, offset=tex.offset,
                     rotation_deg=tex.rotation_deg, name=f"{label} A (alpha)", texcoord=tex.texcoord)
    if slot.image is not None:
        cache.setdefault(key, t)
    return t


class OpacityTexture(Texture):
    """glTF coverage: ``factor x texture x vertex alpha`` (1 channel; either texture may be None)."""

    channels = 1

    def __init__(self, factor, texture=None, vertex=None):
        self.factor = float(factor)
        self.texture = texture
        self.vertex = vertex

    @property
    def needs_footprint(self):
        """Whether the texture or the vertex alpha reads a footprint."""
        return footprinted(self.texture, self.vertex)

    def compiled_scalar(self):
        """The factor times the texture's compiled scalar form (:meth:`pyrt.textures.Texture.compiled_scalar`);
        None with a vertex alpha or without a texture."""
        if self.vertex is not None or self.texture is None:
            return None
        inner = self.texture.compiled_scalar()
        return None if inner is None else (inner[0], inner[1], inner[2] * self.factor)

    def evaluate(self, ctx):
        """The product (N, 1) at the hits of ``ctx``."""
        out = np.full((ctx.n_hits, 1), self.factor)
        for t in (self.texture, self.vertex):
            if t is not None:
                out = out * np.asarray(t.evaluate(ctx), dtype=np.float64).reshape(ctx.n_hits, -1)[:, :1]
        return out


def uses_alpha(params):
    """True when the loaded parameters ask for a coverage alpha (a glTF MASK or BLEND material)."""
    return isinstance(params, PBRParams) and ALPHA_MODES.get(params.alpha_mode, "opaque") != "opaque"


def apply_coverage(material, params, vertex_alpha=None):
    """Set ``material``'s coverage from glTF parameters (:class:`PBRParams`; other formats: nothing).

    ``vertex_alpha`` (a 1-channel texture, COLOR_0's alpha) multiplies the coverage alpha. Returns ``material``.
    """
    if not isinstance(params, PBRParams):
        return material
    material.set_coverage(double_sided=bool(params.double_sided))
    if not uses_alpha(params):
        return material
    factor = float(np.clip(params.base_color_factor[3], 0.0, 1.0))
    tex = params.alpha_texture
    opacity = factor if tex is None and vertex_alpha is None else OpacityTexture(factor, tex, vertex_alpha)
    return material.set_coverage(opacity=opacity, alpha_mode=ALPHA_MODES[params.alpha_mode],
                                 alpha_cutoff=float(np.clip(params.alpha_cutoff, 0.0, 1.0)))
