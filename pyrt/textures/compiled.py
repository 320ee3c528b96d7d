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
=============  ==============================================================================

The table's flat data is the records (``n x RECORD``) followed by the image textures' texels (decoded, float64,
row-major ``(H, W, 3)``): :func:`pack_table`.
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

#: parameters per texture record
RECORD = 16
#: type tags (0 is no texture)
CHECKER_UV, IMAGE = 1, 2
#: the wrap modes' codes (:func:`pyrt.shaders.textures.wrap_index`)
WRAPS = ("repeat", "clamp", "mirror")


@register_jitable(inline="always")
def texture_rgb(tags, pars, t, u, v):
    """Texture ``t`` of the table ``(tags, pars)`` at uv ``(u, v)``: an RGB tuple. ``pars`` is the record table's
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
    return 0.0, 0.0, 0.0


@register_jitable
def wrap_index(i, n, mode):
    """:func:`pyrt.shaders.textures.wrap_index` of one index (``mode``: 0 repeat, 1 clamp, 2 mirror)."""
    if mode == 0:
        return i % n
    if mode == 1:
        return min(max(i, 0), n - 1)
    j = i % (2 * n)
    return 2 * n - 1 - j if j >= n else j


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
    x0, y0 = math.floor(x), math.floor(y)
    fx, fy = x - x0, y - y0
    ix, iy = int(x0), int(y0)
    c0, c1 = wrap_index(ix, w, wu), wrap_index(ix + 1, w, wu)
    r0, r1 = wrap_index(iy, h, wv) * w, wrap_index(iy + 1, h, wv) * w
    w0, w1, w2, w3 = (1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy
    k0, k1, k2, k3 = o + 3 * (r0 + c0), o + 3 * (r0 + c1), o + 3 * (r1 + c0), o + 3 * (r1 + c1)
    r = w0 * pars[k0] + w1 * pars[k1] + w2 * pars[k2] + w3 * pars[k3]
    g = w0 * pars[k0 + 1] + w1 * pars[k1 + 1] + w2 * pars[k2 + 1] + w3 * pars[k3 + 1]
    bb = w0 * pars[k0 + 2] + w1 * pars[k1 + 2] + w2 * pars[k2 + 2] + w3 * pars[k3 + 2]
    if pars[b + 6] != 0.0:
        return float(np.float32(r)), float(np.float32(g)), float(np.float32(bb))
    return r, g, bb


def pack_table(tags, records, texels):
    """The texture table: ``(tags (n,) int64, data (rows, RECORD) float64)``, the records then the texels of the
    image textures (``texels[i]``: None, or record ``i``'s decoded (H, W, 3) texels; their records' offset field
    is set here to where they start in the flat data). One zero row when empty (Numba needs a shape)."""
    if not tags:
        return np.zeros(1, dtype=np.int64), np.zeros((1, RECORD))
    recs = np.stack([np.asarray(r, dtype=np.float64) for r in records])
    parts, at = [], recs.size
    for i, tx in enumerate(texels):
        if tx is not None:
            recs[i, 2] = at
            parts.append(np.ravel(np.asarray(tx, dtype=np.float64)))
            at += parts[-1].size
    flat = np.concatenate([recs.ravel(), *parts, np.zeros(-at % RECORD)])
    return np.asarray(tags, dtype=np.int64), np.ascontiguousarray(flat.reshape(-1, RECORD))


def image_record(tex):
    """``(IMAGE, record, texels)`` of a :class:`pyrt.ImageTexture` read with the ``nearest`` or ``bilinear`` filter,
    RGB, from UV set 0 (the decoded level 0 as its texels); None for any other (the footprint filters need ray
    differentials)."""
    if tex.filter not in ("nearest", "bilinear") or tex.channels != 3 or tex.texcoord != 0:
        return None
    img = tex.image
    rec = np.zeros(RECORD)
    rec[0], rec[1] = img.shape[0], img.shape[1]
    rec[3], rec[4] = (WRAPS.index(m) for m in tex.wrap)
    rec[5] = 0.0 if tex.filter == "nearest" else 1.0
    rec[6] = 1.0 if img.dtype == np.float32 else 0.0
    if tex.scale != (1.0, 1.0) or tex.offset != (0.0, 0.0) or tex.rotation_deg != 0.0:
        rot = np.deg2rad(tex.rotation_deg)
        c, s = np.cos(rot), np.sin(rot)
        sx, sy = tex.scale
        rec[7] = 1.0
        rec[8:12] = (c * sx, s * sx, -s * sy, c * sy)          # transform_uv's lin_t, row-major
        rec[12:14] = tex.offset
    return IMAGE, rec, img
