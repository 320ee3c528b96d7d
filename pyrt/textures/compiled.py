"""The texture family's compiled form: type tags, parameter records and the lookup switch.

A texture the compiled kernel can read packs itself into one row of the texture table
(:meth:`pyrt.textures.Texture.compiled_record`: a tag and :data:`RECORD` float64 parameters). Layouts:

=============  ==============================================================================
CHECKER_UV     0-2 colour0, 3-5 colour1 (constant RGB), 6-7 scale (u, v): the unfiltered checker
               (:func:`pyrt.shaders.noise.checker`) in UV space
IMAGE          an RGB :class:`pyrt.ImageTexture` with the ``nearest`` or ``bilinear`` filter (no footprint): 0 H,
               1 W, 2 where its texels start in the table's flat data, 3-4 wrap (u, v: :data:`WRAPS`), 5 filter (0
               nearest, 1 bilinear), 6 1 when the lookup is rounded to float32 (as the NumPy lookup casts to its
               texels' dtype), 7 1 when the UV transform is not the identity, 8-11 its linear part ``uv @ L``
               (``L[0,0], L[0,1], L[1,0], L[1,1]``), 12-13 its offset
MIP            an RGB :class:`pyrt.ImageTexture` with the ``trilinear`` filter: the IMAGE fields 0-4 and 6-13, 5 the
               number of MIP levels, 14 the footprint scale; its data block is the levels' offsets in the block then
               every level's texels (:mod:`pyrt.textures.compiled_mip`)
VERTEX         per-vertex RGB colours bound to meshes (:class:`pyrt.io.assets.VertexColorTexture`); no fields: the
               colours are packed with the geometry (:mod:`pyrt.integrators.compiled_vertex`) and read only as a
               material's :data:`pyrt.materials.compiled.VERTEX_COLOR`, never looked up by uv
=============  ==============================================================================

The table's flat data is the records (``n x RECORD``) followed by the image textures' texels (decoded, float64,
row-major ``(H, W, 3)``): :func:`pack_table`. Lookups take the hit's UV footprint ``fp = (du/dx, dv/dx, du/dy,
dv/dy)`` (zeros where the ray carries no differentials); only MIP reads it.
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

from pyrt.textures.compiled_mip import WRAPS, MipLevels, bilinear_rgb, mip_record, mip_rgb, wrap_index  # noqa: F401

#: parameters per texture record
RECORD = 16
#: type tags (0 is no texture)
CHECKER_UV, IMAGE, MIP, VERTEX = 1, 2, 3, 4


@register_jitable(forceinline=True)
def texture_rgb(tags, pars, t, u, v, fp):
    """Texture ``t`` of the table ``(tags, pars)`` at uv ``(u, v)`` with the UV footprint ``fp`` (a 4-tuple, module
    notes): an RGB tuple. ``pars`` is the record table's
    flat data (:func:`pyrt.core.unmanaged.pointer`: row ``t`` at ``t * RECORD``; a pointer binds no array, so the
    per-sample code pays no reference counting). Branch-free but for the tag: the cell parity without ``%``."""
    b = t * RECORD
    if tags[t] == CHECKER_UV:
        cells = math.floor(u * pars[b + 6]) + math.floor(v * pars[b + 7])
        odd = cells - 2.0 * math.floor(0.5 * cells)
        return (pars[b] + (pars[b + 3] - pars[b]) * odd, pars[b + 1] + (pars[b + 4] - pars[b + 1]) * odd,
                pars[b + 2] + (pars[b + 5] - pars[b + 2]) * odd)
    if tags[t] == IMAGE:
        return image_rgb(pars, b, u, v)
    if tags[t] == MIP:
        return mip_rgb(pars, b, u, v, fp)
    return 0.0, 0.0, 0.0


@register_jitable
def image_rgb(pars, b, u, v):
    """The IMAGE record at ``pars[b:]`` looked up at mesh uv ``(u, v)``: the UV transform
    (:func:`pyrt.shaders.textures.transform_uv`), then :func:`pyrt.shaders.textures.lookup_nearest` or
    :func:`~pyrt.shaders.textures.lookup_bilinear` (texel centres at integers, row 0 at the top; the four taps'
    weights in float64, the sum rounded to float32 where the NumPy lookup's dtype is)."""
    if pars[b + 7] != 0.0:
        u, v = u * pars[b + 8] + v * pars[b + 10] + pars[b + 12], u * pars[b + 9] + v * pars[b + 11] + pars[b + 13]
    h, w = int(pars[b]), int(pars[b + 1])
    o = int(pars[b + 2])
    wu, wv = int(pars[b + 3]), int(pars[b + 4])
    x, y = u * w - 0.5, (1.0 - v) * h - 0.5
    if pars[b + 5] == 0.0:
        k = o + 3 * (wrap_index(int(math.floor(y + 0.5)), h, wv) * w + wrap_index(int(math.floor(x + 0.5)), w, wu))
        return pars[k], pars[k + 1], pars[k + 2]
    r, g, bb = bilinear_rgb(pars, o, h, w, wu, wv, x, y)
    if pars[b + 6] != 0.0:
        return float(np.float32(r)), float(np.float32(g)), float(np.float32(bb))
    return r, g, bb


def pack_table(tags, records, texels):
    """The texture table: ``(tags (n,) int64, data (rows, RECORD) float64)``, the records then the texels of the
    image textures (``texels[i]``: None, record ``i``'s decoded (H, W, 3) texels, or a MIP record's
    :class:`pyrt.textures.compiled_mip.MipLevels`, made into its block here; their records' offset field is set here
    to where they start in the flat data). One zero row when empty (Numba needs a shape)."""
    if not tags:
        return np.zeros(1, dtype=np.int64), np.zeros((1, RECORD))
    recs = np.stack([np.asarray(r, dtype=np.float64) for r in records])
    sizes = [0 if tx is None else (tx.size if isinstance(tx, MipLevels) else np.size(tx)) for tx in texels]
    at = recs.size
    total = at + sum(sizes)
    # one allocation, each texel written once (converted on the way in): the copies of concatenating made the
    # table 4x slower (1.6 s for three 2048² pyramids) and held them twice
    flat = np.zeros(total + (-total % RECORD))
    flat[:recs.size] = recs.ravel()
    for i, (tx, n) in enumerate(zip(texels, sizes)):
        if tx is None:
            continue
        flat[i * RECORD + 2] = at
        if isinstance(tx, MipLevels):
            tx.write(flat[at:at + n])
        else:
            flat[at:at + n] = np.ravel(tx)
        at += n
    return np.asarray(tags, dtype=np.int64), flat.reshape(-1, RECORD)


def image_record(tex):
    """``(IMAGE, record, texels)`` of a :class:`pyrt.ImageTexture` read with the ``nearest`` or ``bilinear`` filter,
    RGB, from UV set 0 (the decoded level 0 as its texels); ``(MIP, record, levels)`` with the ``trilinear`` filter
    (:func:`pyrt.textures.compiled_mip.mip_record`); None for any other (bicubic, anisotropic, grey, other UV
    sets)."""
    if tex.channels != 3 or tex.texcoord != 0 or tex.filter not in ("nearest", "bilinear", "trilinear"):
        return None
    if tex.filter == "trilinear":
        return (MIP,) + mip_record(tex, np.zeros(RECORD), transform_fields(tex))
    img = tex.image
    rec = np.zeros(RECORD)
    rec[0], rec[1] = img.shape[0], img.shape[1]
    rec[3], rec[4] = (WRAPS.index(m) for m in tex.wrap)
    rec[5] = 0.0 if tex.filter == "nearest" else 1.0
    rec[6] = 1.0 if img.dtype == np.float32 else 0.0
    rec[7:14] = transform_fields(tex)
    return IMAGE, rec, img


def transform_fields(tex):
    """Record fields 7-13 of an image texture: 1 when its UV transform is not the identity, the linear part
    (:func:`pyrt.shaders.textures.transform_uv`'s ``lin_t``, row-major), the offset."""
    out = np.zeros(7)
    if tex.scale != (1.0, 1.0) or tex.offset != (0.0, 0.0) or tex.rotation_deg != 0.0:
        rot = np.deg2rad(tex.rotation_deg)
        c, s = np.cos(rot), np.sin(rot)
        sx, sy = tex.scale
        out[0] = 1.0
        out[1:5] = (c * sx, s * sx, -s * sy, c * sy)
        out[5:7] = tex.offset
    return out
