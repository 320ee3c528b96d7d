"""Vertex tangents generated from a mesh's UVs, for normal maps of meshes that do not carry their own (glTF
primitives without ``TANGENT``: the glTF spec asks viewers for MikkTSpace's).

:func:`vertex_tangents` follows MikkTSpace's main rules (Mikkelsen 2008): each triangle's tangent is its UV
parameterisation's ``dpdu``, normalised; at a vertex, the tangents of the triangles around it are projected onto
the plane of the vertex normal, normalised, weighted by the triangle's angle at that corner and summed; a vertex
whose triangles disagree on the handedness (the sign of ``(n x dpdu) . dpdv``, ``n`` the vertex normal: a
mirrored-UV seam whose vertices are shared) gets no tangent (zero), so the triangles there use their own UV tangents
(:meth:`pyrt.geometry.SurfaceBatch.shading_tangents`), where MikkTSpace would split the vertex. What it does not
do: MikkTSpace also splits vertices whose tangents differ by more than a threshold angle and treats degenerate
triangles by merging with their neighbours; here a triangle with a degenerate UV map (``|det| <= 1e-20``) adds
nothing, and vertices are never split (the mesh keeps its vertex buffer). The result is smooth across triangles,
where each triangle's own ``dpdu`` is constant per triangle and turns the normal map's frame at every edge of a
curved, normal-mapped low-poly surface.
"""
from __future__ import annotations

import numpy as np

from pyrt.geometry.uvsets import uv_derivatives
from pyrt.shaders.vec import cross, divide_rows, dot, norm, reject, take_rows


def _corner_angles(e01, e02, e12):
    """(F, 3) interior angles at corners 0, 1, 2 of triangles with edges ``p1 - p0``, ``p2 - p0``, ``p2 - p1``."""
    def angle(a, b):
        return np.arctan2(norm(cross(a, b)), dot(a, b))
    return np.column_stack([angle(e01, e02), angle(-e01, e12), angle(-e02, -e12)])


#: faces per accumulation step of :func:`vertex_tangents`: its temporaries are ~20 (chunk, 3) float64 arrays (~0.5 GB
#: at once for a 5 M-triangle mesh without chunks, ~100 MB with)
FACE_CHUNK = 1 << 18


def _accumulate(v, f, n, uv, acc, weight):
    """Add the triangles ``f``'s projected, angle-weighted unit ``dpdu`` to their corners' sums ``acc`` (3, 2V) and
    weights ``weight`` (2V,) (:func:`vertex_tangents`)."""
    n_v = v.shape[0]
    p0, p1, p2 = (take_rows(v, f[:, k]) for k in range(3))
    t0, t1, t2 = (take_rows(uv, f[:, k]) for k in range(3))
    e1, e2 = p1 - p0, p2 - p0
    dpdu, dpdv, ok = uv_derivatives(e1, e2, t1 - t0, t2 - t0)
    ang = _corner_angles(e1, e2, p2 - p1)
    for k in range(3):
        idx = f[:, k]
        nk = take_rows(n, idx)
        t = reject(dpdu, nk)                                # projected onto the vertex normal's plane
        length = norm(t)
        good = ok & (length > 0) & (ang[:, k] > 0)
        t = divide_rows(t, np.where(good, length, 1.0))
        w = np.where(good, ang[:, k], 0.0)
        side = (dot(cross(nk, dpdu), dpdv) < 0).astype(np.int64)    # left-handed seen from the vertex normal
        flat = side * n_v + idx
        for c in range(3):
            acc[c] += np.bincount(flat, weights=t[:, c] * w, minlength=2 * n_v)
        weight += np.bincount(flat, weights=w, minlength=2 * n_v)


def vertex_tangents(vertices, faces, normals, uv):
    """(V, 4) per-vertex tangents ``(x, y, z, w)`` of a mesh (object space, ``w`` = +-1 the bitangent's sign,
    bitangent = ``w (n x t)`` as glTF's ``TANGENT``) from its UVs ``uv`` (V, 2) and unit vertex ``normals``
    (V, 3); rows of zeros where a vertex gets none (module docstring)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    n = np.asarray(normals, dtype=np.float64)
    uv = np.asarray(uv, dtype=np.float64)
    n_v = v.shape[0]
    # per component, the tangent sums of the right-handed (rows 0 .. V-1) and left-handed (V .. 2V-1) triangles
    acc = np.zeros((3, 2 * n_v))
    weight = np.zeros(2 * n_v)
    for lo in range(0, f.shape[0], FACE_CHUNK):      # a few (chunk, 3) temporaries at a time, whatever the mesh
        _accumulate(v, f[lo:lo + FACE_CHUNK], n, uv, acc, weight)
    out = np.zeros((n_v, 4))
    right = weight[:n_v] > 0
    left = weight[n_v:] > 0
    for sel, s, sign in ((right & ~left, 0, 1.0), (left & ~right, 1, -1.0)):
        t = acc[:, s * n_v:(s + 1) * n_v].T[sel]
        t = reject(t, n[sel])
        length = norm(t)
        keep = length > 1e-12
        rows = np.flatnonzero(sel)[keep]
        out[rows, :3] = divide_rows(t[keep], length[keep])
        out[rows, 3] = sign
    return out
