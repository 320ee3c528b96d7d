"""A texture budget for loading models: images larger than a render can read are reduced when they are decoded.

At 640 x 480 a pixel usually covers several texels of an 8192² map, yet its level 0 is decoded and kept, and level 1
is built from it: the helmet-like model of ``tools/make_textured_model.py`` with five 8192² maps took 19.3 s and
2.3 GB for the whole preview, 12.1 s and 0.83 GB with the budget (docs/preview.md, "texture budget": interleaved
medians). ``max_texture`` (:func:`pyrt.io.assets.load_asset`, the
previewer's ``--max-texture``) reduces an image whose longer side exceeds it by the power of two ``f`` that brings it
within, as it is decoded: each ``f x f`` block of texels becomes their mean, in linear light for colour images
(sRGB codes decoded, averaged, encoded again and rounded to the image's own codes), in code values for data maps and
alpha. That is the box filter of pyrt's own MIP levels (:mod:`pyrt.shaders.mip`), so the reduced image is level
``log2 f`` of the full one up to the rounding to codes (at most half a code), and a render that would read only
levels at or above it sees the same texels. The last ``H mod f`` rows and ``W mod f`` columns, if any, are dropped.
Where a render would read finer levels (a close-up of a small part of a large atlas), the reduction shows: it is a
documented, switchable choice (``max_texture=None`` keeps every image whole), and the loader's warnings name every
image it reduced.
"""
from __future__ import annotations

import numpy as np

from pyrt.shaders.color import srgb_encode
from pyrt.shaders.mip import pair_table, reduce_coded_level, reduce_levels
from pyrt.textures.image import decode_table

#: rows of the full image reduced at a time (bounds the float32 working set of a reduction: ~rows x W x C x 4 bytes)
BLOCK_ROWS = 512


def reduction_factor(shape, max_size):
    """The power of two ``f`` (>= 1) that brings an image of ``shape`` (H, W, ...) within ``max_size`` on its longer
    side (1 when ``max_size`` is None or it already fits)."""
    if max_size is None:
        return 1
    f = 1
    while max(shape[0], shape[1]) > f * max_size:
        f *= 2
    return f


def reduce_texels(codes, f, srgb_channels=0):
    """``codes`` (H, W, C) uint8 / uint16 reduced by ``f``: each ``f x f`` block averaged, the first ``srgb_channels``
    channels in linear light (sRGB-decoded, averaged, encoded), the others as code values; rounded to the codes'
    dtype. Returns ``(H // f, W // f, C)``.

    The averages are pyrt's MIP reductions of the decoded texels (:func:`pyrt.shaders.mip.reduce_coded_level` for
    8-bit codes, then :func:`pyrt.shaders.mip.reduce_levels`), over strips of ``BLOCK_ROWS`` rows (whole ``f x f``
    blocks, so the strips give the same numbers as the whole image)."""
    a = np.asarray(codes)
    if f == 1:
        return a
    if a.ndim == 2:
        return reduce_texels(a[:, :, None], f, srgb_channels)[:, :, 0]
    h, w, c = a.shape[0] // f, a.shape[1] // f, a.shape[2]
    out = np.empty((h, w, c), dtype=a.dtype)
    top = np.iinfo(a.dtype).max
    groups = [(0, srgb_channels, "srgb"), (srgb_channels, c, "linear")]
    step = max(1, BLOCK_ROWS // f)
    for lo, hi, decoding in groups:
        if hi <= lo:
            continue
        table = decode_table(a.dtype, decoding)
        pairs = pair_table(table) if a.dtype == np.uint8 else None
        for r0 in range(0, h, step):
            r1 = min(h, r0 + step)
            blk = a[r0 * f:r1 * f, :w * f, lo:hi]
            if pairs is not None:
                lin = reduce_levels(reduce_coded_level(blk, table, pairs), f.bit_length() - 2)
            else:
                lin = reduce_levels(table[blk], f.bit_length() - 1)
            if decoding == "srgb":
                lin = srgb_encode(lin)
            out[r0:r1, :, lo:hi] = np.clip(np.rint(lin * np.float32(top)), 0, top).astype(a.dtype)
    return out
