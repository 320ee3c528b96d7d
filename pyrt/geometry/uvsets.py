"""Texture-coordinate sets beyond the first (glTF ``TEXCOORD_1``, ...) and the per-set surface formulas.

A mesh always has UV set 0 (:attr:`MeshData.uv <pyrt.geometry.mesh_data.MeshData>`, the fields ``uv``,
``duvdx``, ``duvdy``, ``dpdu``, ``dpdv`` of a :class:`~pyrt.geometry.surface.SurfaceBatch`); further sets are
kept in ``MeshData.uv_sets`` ``{k: (V, 2)}`` only when a material reads them (the asset loaders drop unused
sets). :meth:`GeometryTable.uv_table <pyrt.geometry.surface.GeometryTable.uv_table>` concatenates set ``k``
over the scene on the first request (zeros for meshes without it), and a batch reconstructs set ``k`` at its
hits only when a texture asks for it (:meth:`SurfaceBatch.uv_set`, :meth:`SurfaceBatch.uv_tangents`): the
interpolated UVs, the footprints from the same barycentric ray differentials as set 0 (so MIP levels are
chosen per set), and the tangents ``dpdu``, ``dpdv`` of that parameterisation (normal maps read in set ``k``).

Set 0 and set ``k`` use the same functions here, in the same arithmetic order: a set ``k`` equal to set 0
gives bit-identical values.
"""
from __future__ import annotations

import numpy as np

from pyrt.shaders.vec import coordinate_frame, scale_rows, take_rows


def combine_rows(s1, a, s2, b):
    """``s1[:, None] * a + s2[:, None] * b`` for (N,) weights and (N, C) rows, column by column (the same
    arithmetic per element; broadcasting over the short axis is several times slower, :mod:`pyrt.shaders.vec`)."""
    out = np.empty(a.shape)
    tmp = np.empty(a.shape[0])
    for c in range(a.shape[1]):
        col = out[:, c]
        np.multiply(s1, a[:, c], out=col)
        col += np.multiply(s2, b[:, c], out=tmp)
    return out


def interpolate_uv(uv0, uv1, uv2, b0, b1, b2):
    """``b0 uv0 + b1 uv1 + b2 uv2`` (N, 2) float64, column by column."""
    uv = combine_rows(b0, uv0, b1, uv1)
    uv += scale_rows(uv2, b2)
    return uv


def uv_derivatives(e1, e2, du1, du2):
    """``(dpdu, dpdv, ok)`` of triangles with edges ``e1, e2`` (N, 3) and UV edges ``du1, du2`` (N, 2): the position's
    derivatives along u and v (N, 3), zero where the UV map is degenerate (``|det| <= 1e-20``, ``ok`` False)."""
    det = du1[:, 0] * du2[:, 1] - du1[:, 1] * du2[:, 0]
    ok = np.abs(det) > 1e-20
    inv = np.divide(1.0, det, out=np.zeros_like(det), where=ok)
    dpdu = (du2[:, 1:2] * e1 - du1[:, 1:2] * e2) * inv[:, None]
    dpdv = (du1[:, 0:1] * e2 - du2[:, 0:1] * e1) * inv[:, None]
    return dpdu, dpdv, ok


def uv_tangents(e1, e2, du1, du2, ng):
    """``(dpdu, dpdv)`` (N, 3) of a triangle with edges ``e1, e2`` (N, 3) and UV edges ``du1, du2`` (N, 2)
    (:func:`uv_derivatives`); where the UV map is degenerate a frame around ``ng`` (N, 3) instead."""
    dpdu, dpdv, ok = uv_derivatives(e1, e2, du1, du2)
    if not np.all(ok):
        s_, t_ = coordinate_frame(ng[~ok])
        dpdu[~ok], dpdv[~ok] = s_, t_
    return dpdu, dpdv


def concat_uv_set(meshes, k):
    """UV set ``k`` >= 1 of every mesh concatenated, (V_total, 2) float64 (zeros for meshes without it), or None
    when no mesh has it."""
    if not any(m.uv_sets and k in m.uv_sets for m in meshes):
        return None
    return np.concatenate([m.uv_sets[k] if m.uv_sets and k in m.uv_sets else np.zeros((m.vertices.shape[0], 2))
                           for m in meshes])


def uv_set_at_hits(table, tri, surf, what):
    """Set ``table`` (V_total, 2) at the hits of ``surf`` (triangles ``tri`` (N, 3)): ``what = "uv"`` ->
    ``(uv, duvdx, duvdy)``, ``"tangents"`` -> ``(dpdu, dpdv)``; zeros (uv) / the set-0 fallback frame
    (tangents) everywhere when ``table`` is None (no mesh has the set)."""
    n = tri.shape[0]
    if table is None:
        table = np.zeros((1, 2))
        tri = np.zeros((n, 3), dtype=np.int64)
    uv0, uv1, uv2 = take_rows(table, tri[:, 0]), take_rows(table, tri[:, 1]), take_rows(table, tri[:, 2])
    du1, du2 = uv1 - uv0, uv2 - uv0
    if what == "uv":
        b = surf.bary
        db = surf.dbary
        return (interpolate_uv(uv0, uv1, uv2, b[:, 0], b[:, 1], b[:, 2]),
                combine_rows(db[:, 0], du1, db[:, 1], du2), combine_rows(db[:, 2], du1, db[:, 3], du2))
    tv = surf.tri_v
    return uv_tangents(tv[:, 1] - tv[:, 0], tv[:, 2] - tv[:, 0], du1, du2, surf.ng)
