"""Crease-angle smooth vertex normals: one function, two documented ways of deciding what is smooth.

:func:`crease_normals` splits a mesh's vertices where the surface is sharper than a crease angle and
gives every output vertex a unit normal. The two callers smooth differently, and each keeps its own
way through the explicit ``weld`` keyword (measured: the two give different normals -- and, for
``"edges"``, a different face order -- on the same mesh, so neither can replace the other without
changing pixels):

- ``weld="position"`` (the asset loader, :mod:`pyrt.io.assets`): corners are welded by exact
  position, so UV seams and unindexed triangle soups (STL) are smoothed; each corner averages the
  faces around its position whose normal is within the crease angle of its own face's normal.
- ``weld="edges"`` (:meth:`pyrt.Scene.add_mesh` with ``smooth="auto"``): faces are smoothed across
  the edges they share by vertex index whose dihedral angle is below the crease angle, transitively
  (connected patches, ``trimesh.graph.smooth_shade``); a UV seam stays a seam. The faces come out
  grouped patch by patch.

Both weight a face's normal by the corner's interior angle (Thürmer & Wüthrich 1998). Everything is
float64.
"""
from __future__ import annotations

import math

import numpy as np
import trimesh

#: Default crease angle (degrees).
DEFAULT_CREASE_ANGLE = 30.0

WELDS = ("position", "edges")


def crease_normals(vertices, faces, crease_angle=DEFAULT_CREASE_ANGLE, *, weld="position"):
    """Smooth vertex normals that keep edges sharper than ``crease_angle`` (degrees).

    Parameters
    ----------
    vertices : (V, 3) float
    faces : (F, 3) int
    crease_angle : float
        Degrees in [0, 180]; 0 gives flat shading, 180 smooths everything.
    weld : {"position", "edges"}
        What is smoothed together (see the module docstring). ``"position"``: corners at the same
        exact position, each against its own face's normal. ``"edges"``: patches of faces connected
        by shared edges below the crease angle (trimesh's ``smooth_shade``).

    Returns
    -------
    src : (V',) int64
        Source vertex of each output vertex (carry positions, UVs and colours with ``uv[src]``).
    faces : (F, 3) int64
        Faces over the output vertices: in the input order for ``"position"``, grouped by patch for
        ``"edges"``.
    normals : (V', 3) float64
        Unit normals. ``"position"``: a degenerate face's own corners get the summed neighbours'
        normal, or (0, 0, 0) if every face around is degenerate.
    """
    if not 0.0 <= crease_angle <= 180.0:
        raise ValueError(f"crease_angle must be in [0, 180] degrees, got {crease_angle}")
    if weld == "position":
        return _crease_by_position(vertices, faces, crease_angle)
    if weld == "edges":
        return _crease_by_edges(vertices, faces, crease_angle)
    raise ValueError(f"weld must be one of {WELDS}, got {weld!r}")


def _crease_by_position(vertices, faces, crease_angle):
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    nf = f.shape[0]
    p = v[f]                                                  # (F, 3, 3)
    fn = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    ln = np.linalg.norm(fn, axis=1, keepdims=True)
    fn = np.divide(fn, ln, out=np.zeros_like(fn), where=ln > 0)
    # interior angle at each corner
    ang = np.zeros((nf, 3))
    for k in range(3):
        a = p[:, (k + 1) % 3] - p[:, k]
        b = p[:, (k + 2) % 3] - p[:, k]
        na = np.linalg.norm(a, axis=1)
        nb = np.linalg.norm(b, axis=1)
        c = np.divide(np.einsum("ij,ij->i", a, b), na * nb, out=np.zeros(nf), where=(na * nb) > 0)
        ang[:, k] = np.arccos(np.clip(c, -1.0, 1.0))
    corner_vertex = f.ravel()                                  # (3F,)
    corner_face = np.repeat(np.arange(nf), 3)
    _, pos_id = np.unique(v, axis=0, return_inverse=True)
    pos_id = pos_id.ravel()[corner_vertex]
    order = np.argsort(pos_id, kind="stable")
    sorted_pos = pos_id[order]
    starts = np.flatnonzero(np.r_[True, sorted_pos[1:] != sorted_pos[:-1]])
    counts = np.diff(np.r_[starts, sorted_pos.size])
    group_of_sorted = np.repeat(np.arange(starts.size), counts)
    # every (corner i, corner j) pair sharing a position; i in sorted order, j over its group
    cnt_i = counts[group_of_sorted]
    total = int(np.sum(cnt_i))
    rep_i = np.repeat(np.arange(sorted_pos.size), cnt_i)
    first = np.repeat(np.cumsum(cnt_i) - cnt_i, cnt_i)
    j_sorted = starts[group_of_sorted][rep_i] + (np.arange(total) - first)
    ci = order[rep_i]
    cj = order[j_sorted]
    fi, fj = corner_face[ci], corner_face[cj]
    cos_lim = math.cos(math.radians(crease_angle))
    ok = np.einsum("ij,ij->i", fn[fi], fn[fj]) >= cos_lim - 1e-12
    ok |= fi == fj
    w = ang.ravel()[cj] * ok
    acc = np.zeros((3 * nf, 3))
    for c in range(3):
        acc[:, c] = np.bincount(ci, weights=w * fn[fj, c], minlength=3 * nf)
    la = np.linalg.norm(acc, axis=1, keepdims=True)
    acc = np.divide(acc, la, out=np.zeros_like(acc), where=la > 0)
    # split vertices whose corners got different normals
    key = np.concatenate([corner_vertex[:, None].astype(np.float64).view(np.int64), acc.view(np.int64)], axis=1)
    _, first_idx, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    src = corner_vertex[first_idx]
    return src.astype(np.int64), inv.reshape(nf, 3).astype(np.int64), acc[first_idx]


def _crease_by_edges(vertices, faces, crease_angle):
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    mesh = trimesh.Trimesh(vertices=v, faces=f, process=False)
    sm = trimesh.graph.smooth_shade(mesh, angle=math.radians(crease_angle), facet_minarea=None)
    out_faces = np.asarray(sm.faces, dtype=np.int64)
    normals = np.asarray(sm.vertex_normals, dtype=np.float64)
    components = sm.metadata.get("original_components")
    if components is None:   # smooth_shade returned a copy (no shared edges): vertices as they are
        return np.arange(v.shape[0], dtype=np.int64), out_faces, normals
    # output face k is input face face_src[k] (smooth_shade appends the patches in order), so each
    # output corner names its source vertex; every output vertex is some face's corner
    face_src = np.concatenate([np.asarray(c, dtype=np.int64).ravel() for c in components])
    src = np.empty(normals.shape[0], dtype=np.int64)
    src[out_faces.ravel()] = f[face_src].ravel()
    return src, out_faces, normals
