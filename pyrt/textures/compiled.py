"""The texture family's compiled form: type tags, parameter records and the lookup switch.

A texture the compiled kernel can read packs itself into one row of the texture table
(:meth:`pyrt.textures.Texture.compiled_record`: a tag and :data:`RECORD` float64 parameters). Layouts:

=============  ==============================================================================
CHECKER_UV     0-2 colour0, 3-5 colour1 (constant RGB), 6-7 scale (u, v): the unfiltered checker
               (:func:`pyrt.shaders.noise.checker`) in UV space
IMAGE          an RGB :class:`pyrt.ImageTexture` with the ``nearest`` or ``bilinear`` filter (no footprint): 0 H,
               1 W, 2 where its texels start in the table's float32 words, 3-4 wrap (u, v: :data:`WRAPS`), 5 filter
               (0 nearest, 1 bilinear), 6 1 when the lookup is rounded to float32 (as the NumPy lookup casts to its
               texels' dtype), 7 1 when the UV transform is not the identity, 8-11 its linear part ``uv @ L``
               (``L[0,0], L[0,1], L[1,0], L[1,1]``), 12-13 its offset
MIP            an RGB :class:`pyrt.ImageTexture` with the ``trilinear`` filter: the IMAGE fields 0-4 and 6-13, 5 the
               number of MIP levels, 14 the footprint scale, 15 where its levels' offsets start in the table's
               float64 words (:mod:`pyrt.textures.compiled_mip`)
VERTEX         per-vertex RGB colours bound to meshes (:class:`pyrt.io.assets.VertexColorTexture`); no fields: the
               colours are packed with the geometry (:mod:`pyrt.integrators.compiled_vertex`) and read only as a
               material's :data:`pyrt.materials.compiled.VERTEX_COLOR`, never looked up by uv
=============  ==============================================================================

Field :data:`UV_SET` (16) of every record is the UV set the texture reads: ``k`` as :func:`image_record` writes it,
then, once packed, 0 for set 0 (the hit's interpolated ``uv``) or where set ``k``'s per-vertex table starts in the
table's float64 words (:func:`pack_table`).

The table's data is one float64 array (:func:`pack_table`): the records (``n x RECORD``), the MIP records' level
offsets, the UV sets ``k >= 1`` its textures read (per vertex of the scene's geometry, ``(V, 2)`` each:
:meth:`pyrt.geometry.GeometryTable.uv_table`), then the image textures' texels as float32 words (two to a float64 word;
row-major ``(H, W, 3)`` per MIP level, the float32 values the NumPy lookups read, so nothing is rounded on the way in).
The lookups read the records through ``pars`` and the texels through :func:`pyrt.core.unmanaged.float32_pointer` of the
same data, indexed in float32 words from its start. Lookups take the hit's uv (set 0) and its *footprint record* ``fp``,
:data:`FP_SIZE` floats: 0-3 set 0's UV footprint ``(du/dx, dv/dx, du/dy, dv/dy)`` (zeros where the ray carries no
differentials; only MIP reads it), 4-6 the hit triangle's vertex indices, 7-9 its barycentrics ``b0, b1, b2``, 10-13
their derivatives ``(db1/dx, db2/dx, db1/dy, db2/dy)`` (zeros without differentials; :func:`footprint`). A texture of UV
set ``k >= 1`` reads its uv and footprint from them and the set's table (:func:`set_uv`: the NumPy path's
:func:`pyrt.geometry.uvsets.uv_set_at_hits`, in its arithmetic order), so every slot reads its own set through the one
lookup.
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

from pyrt.core.memory import zeroed
from pyrt.core.unmanaged import float32_pointer
from pyrt.textures.compiled_mip import WRAPS, TexelBlock, bilinear_rgb, mip_record, mip_rgb, wrap_index  # noqa: F401

#: parameters per texture record
RECORD = 17
#: type tags (0 is no texture)
CHECKER_UV, IMAGE, MIP, VERTEX = 1, 2, 3, 4
#: the record field of the UV set a texture reads (module notes)
UV_SET = 16
#: floats in a footprint record (module notes)
FP_SIZE = 14
#: the footprint record of no hit (zero footprints; a texture of a UV set k >= 1 reads vertex 0 of its set)
NO_FOOTPRINT = (0.0,) * FP_SIZE
#: no differentials: :func:`footprint`'s ``d``
NO_DIFFS = (0.0,) * 8


@register_jitable(forceinline=True)
def footprint(d, i0, i1, i2, b0, b1, b2):
    """The footprint record (module notes) of a hit on the triangle of vertices ``i0, i1, i2`` at barycentrics
    ``(b0, b1, b2)``, with ``d = (du/dx, dv/dx, du/dy, dv/dy, db1/dx, db2/dx, db1/dy, db2/dy)`` (set 0's UV footprint
    and the barycentric derivatives; :data:`NO_DIFFS` without differentials)."""
    return (d[0], d[1], d[2], d[3], float(i0), float(i1), float(i2), b0, b1, b2, d[4], d[5], d[6], d[7])


@register_jitable
def set_uv(pars, o, fp):
    """``(u, v, (du/dx, dv/dx, du/dy, dv/dy))`` of the UV set whose per-vertex table starts at ``pars[o]`` at the hit
    of the footprint record ``fp``: the set interpolated at the barycentrics (``(b0 uv0 + b1 uv1) + b2 uv2``) and its
    footprint from the barycentric derivatives and the set's edges (``db1 (uv1 - uv0) + db2 (uv2 - uv0)``), as
    :func:`pyrt.geometry.uvsets.uv_set_at_hits`."""
    k0, k1, k2 = o + 2 * int(fp[4]), o + 2 * int(fp[5]), o + 2 * int(fp[6])
    u0, v0, u1, v1, u2, v2 = pars[k0], pars[k0 + 1], pars[k1], pars[k1 + 1], pars[k2], pars[k2 + 1]
    b0, b1, b2 = fp[7], fp[8], fp[9]
    du1, dv1, du2, dv2 = u1 - u0, v1 - v0, u2 - u0, v2 - v0
    bx1, bx2, by1, by2 = fp[10], fp[11], fp[12], fp[13]
    return (b0 * u0 + b1 * u1 + u2 * b2, b0 * v0 + b1 * v1 + v2 * b2,
            (bx1 * du1 + bx2 * du2, bx1 * dv1 + bx2 * dv2, by1 * du1 + by2 * du2, by1 * dv1 + by2 * dv2))


@register_jitable(forceinline=True)
def texture_rgb(tags, pars, t, u, v, fp):
    """Texture ``t`` of the table ``(tags, pars)`` at the hit of set-0 uv ``(u, v)`` and footprint record ``fp``
    (module notes): an RGB tuple, read in the texture's UV set (:func:`set_uv` for a set ``k >= 1``). ``pars`` is
    the table's flat data (:func:`pyrt.core.unmanaged.pointer`: row ``t`` at ``t * RECORD``, the texels in its
    float32 words; a pointer binds no array, so the per-sample code pays no reference counting). Branch-free but
    for the tag and the set: the cell parity without ``%``."""
    b = t * RECORD
    fp4 = (fp[0], fp[1], fp[2], fp[3])
    if pars[b + UV_SET] != 0.0:
        u, v, fp4 = set_uv(pars, int(pars[b + UV_SET]), fp)
    if tags[t] == CHECKER_UV:
        cells = math.floor(u * pars[b + 6]) + math.floor(v * pars[b + 7])
        odd = cells - 2.0 * math.floor(0.5 * cells)
        return (pars[b] + (pars[b + 3] - pars[b]) * odd, pars[b + 1] + (pars[b + 4] - pars[b + 1]) * odd,
                pars[b + 2] + (pars[b + 5] - pars[b + 2]) * odd)
    if tags[t] == IMAGE:
        return image_rgb(pars, b, u, v)
    if tags[t] == MIP:
        return mip_rgb(pars, b, u, v, fp4)
    return 0.0, 0.0, 0.0


@register_jitable
def image_rgb(pars, b, u, v):
    """The IMAGE record at ``pars[b:]`` looked up at mesh uv ``(u, v)``: the UV transform
    (:func:`pyrt.shaders.textures.transform_uv`), then :func:`pyrt.shaders.textures.lookup_nearest` or
    :func:`~pyrt.shaders.textures.lookup_bilinear` (texel centres at integers, row 0 at the top; the four float32
    taps weighted in float64, the sum rounded to float32 where the NumPy lookup's dtype is)."""
    if pars[b + 7] != 0.0:
        u, v = u * pars[b + 8] + v * pars[b + 10] + pars[b + 12], u * pars[b + 9] + v * pars[b + 11] + pars[b + 13]
    h, w = int(pars[b]), int(pars[b + 1])
    o = int(pars[b + 2])
    wu, wv = int(pars[b + 3]), int(pars[b + 4])
    tx = float32_pointer(pars)
    x, y = u * w - 0.5, (1.0 - v) * h - 0.5
    if pars[b + 5] == 0.0:
        k = o + 3 * (wrap_index(int(math.floor(y + 0.5)), h, wv) * w + wrap_index(int(math.floor(x + 0.5)), w, wu))
        return float(tx[k]), float(tx[k + 1]), float(tx[k + 2])
    r, g, bb = bilinear_rgb(tx, o, h, w, wu, wv, x, y)
    if pars[b + 6] != 0.0:
        return float(np.float32(r)), float(np.float32(g)), float(np.float32(bb))
    return r, g, bb


def pack_table(tags, records, texels, uv_sets=None):
    """The texture table: ``(tags (n,) int64, data (rows, RECORD) float64)`` (the module notes). ``texels[i]`` is
    None or record ``i``'s :class:`pyrt.textures.compiled_mip.TexelBlock`, written here straight into the table's
    float32 words (one copy of each level, no float64 or concatenated intermediate); ``uv_sets`` ``{k: (V, 2)
    float64}`` the per-vertex UV sets ``k >= 1`` the records' :data:`UV_SET` fields name (each must be there). The
    records' fields 2 (and 15 of a MIP record) and :data:`UV_SET` are set here. One zero row when empty (Numba
    needs a shape)."""
    if not tags:
        return np.zeros(1, dtype=np.int64), np.zeros((1, RECORD))
    recs = np.stack([np.asarray(r, dtype=np.float64) for r in records])
    sizes = [[] if tx is None else tx.level_sizes() for tx in texels]
    n_offsets = sum(len(s) for tag, s in zip(tags, sizes) if tag == MIP)
    sets = sorted({int(k) for k in recs[:, UV_SET] if k >= 1})
    set_at, at = {}, recs.size + n_offsets
    for k in sets:
        set_at[k] = at
        at += 2 * uv_sets[k].shape[0]
    words = at                                       # float64 words before the texels
    total = words + (sum(map(sum, sizes)) + 1) // 2
    flat = zeroed(total + (-total % RECORD))         # pages mapped as the texels are written (no huge-page stalls)
    flat32 = flat.view(np.float32)
    for k in sets:
        flat[set_at[k]:set_at[k] + 2 * uv_sets[k].shape[0]] = np.asarray(uv_sets[k], dtype=np.float64).ravel()
    recs[:, UV_SET] = [set_at.get(int(k), 0) for k in recs[:, UV_SET]]
    at, lo = 2 * words, recs.size                    # next texel (float32 word), next level offset (float64 word)
    for i, (tag, tx, levels) in enumerate(zip(tags, texels, sizes)):
        if tx is None:
            continue
        recs[i, 2] = at
        tx.write(flat32[at:at + sum(levels)])
        if tag == MIP:
            recs[i, 15] = lo
            flat[lo:lo + len(levels)] = at + np.concatenate([[0], np.cumsum(levels[:-1])])
            lo += len(levels)
        at += sum(levels)
    flat[:recs.size] = recs.ravel()
    return np.asarray(tags, dtype=np.int64), flat.reshape(-1, RECORD)


def image_record(tex):
    """``(IMAGE, record, texels)`` of a :class:`pyrt.ImageTexture` read with the ``nearest`` or ``bilinear`` filter,
    RGB, from any UV set (its level 0 as its texels, a :class:`pyrt.textures.compiled_mip.TexelBlock` of one level);
    ``(MIP, record, texels)`` with the ``trilinear`` filter (:func:`pyrt.textures.compiled_mip.mip_record`); None
    for any other (:func:`image_refusal` says why)."""
    if image_refusal(tex) is not None:
        return None
    if tex.filter == "trilinear":
        out = (MIP,) + mip_record(tex, np.zeros(RECORD), transform_fields(tex))
        out[1][UV_SET] = tex.texcoord
        return out
    rec = np.zeros(RECORD)
    rec[UV_SET] = tex.texcoord
    rec[0], rec[1] = tex.texels.shape[:2]
    rec[3], rec[4] = (WRAPS.index(m) for m in tex.wrap)
    rec[5] = 0.0 if tex.filter == "nearest" else 1.0
    rec[6] = 1.0 if (tex.table if tex.table is not None else tex.texels).dtype == np.float32 else 0.0
    rec[7:14] = transform_fields(tex)
    return IMAGE, rec, TexelBlock(tex, 1)


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


def image_refusal(tex):
    """Why the compiled kernel cannot read the :class:`pyrt.ImageTexture` ``tex`` (a phrase naming it), or None
    when it can (:func:`image_record`)."""
    parts = []
    if tex.channels != 3:
        parts.append(f"has {tex.channels} channel(s), the kernel reads RGB")
    if tex.filter not in ("nearest", "bilinear", "trilinear"):
        parts.append(f"filter {tex.filter!r}")
    label = tex.name or tex.path
    name = f" {label!r}" if label else ""
    return None if not parts else f"texture {type(tex).__name__}{name}: " + ", ".join(parts)

