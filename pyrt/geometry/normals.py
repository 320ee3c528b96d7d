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

from pyrt.shaders.vec import cross, divide_rows, norm, scale_rows

#: Default crease angle (degrees).
DEFAULT_CREASE_ANGLE = 30.0

WELDS = ("position", "edges")


def crease_normals(vertices, faces, crease_angle=DEFAULT_CREASE_ANGLE, *, weld="position", groups=None):
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
    groups : (V,) int, optional (``"position"`` only)
        Vertices of different groups are never welded: several meshes in one call, each vertex labelled by its
        mesh, get the normals each would get alone, in the same order (output vertices follow their source
        vertices, so each mesh's are one contiguous run), at the cost of one call instead of one per mesh.

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
        return _crease_by_position(vertices, faces, crease_angle, groups)
    if groups is not None:
        raise ValueError("crease_normals: groups are supported with weld='position' only")
    if weld == "edges":
        return _crease_by_edges(vertices, faces, crease_angle)
    raise ValueError(f"weld must be one of {WELDS}, got {weld!r}")


def _crease_by_position(vertices, faces, crease_angle, groups=None):
    """Position-welded crease normals (see :func:`crease_normals`), in two passes.

    Pass 1 (every corner): the corners of each position are summed into one angle-weighted normal (``bincount``
    in corner order). A position whose face normals all lie within half the crease angle of that sum's
    direction has every pair of faces within the crease angle (triangle inequality on the sphere), so each of
    its corners gets that sum: no pairs are formed. Pass 2 (the other positions only: creases, cusps,
    degenerate faces): every pair of corners sharing the position, each corner summing the faces within the
    crease angle of its own. Both passes add the same terms in the same order as one all-pairs pass, so the
    normals are bitwise those of the all-pairs method (tested); memory is O(corners) instead of O(corners x
    valence) (5.2 M triangles: ~1 GB instead of ~10 GB).
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    nf = f.shape[0]
    fn, ang = _face_normals_and_angles(v, f)
    corner_vertex = f.ravel()                                  # (3F,), corner 3 i + k is corner k of face i
    pos_of_vertex, n_pos = _position_ids(v, groups)
    if n_pos == v.shape[0]:          # every vertex at its own position (indexed meshes): label positions by vertex
        pos_of_vertex = np.arange(n_pos)
        cpos = corner_vertex
    else:
        cpos = np.take(pos_of_vertex, corner_vertex)           # (3F,) position group of each corner
    # pass 1: one angle-weighted sum per position; the same terms, in corner order, as pass 2's pairs
    acc_pos = np.empty((n_pos, 3))
    for c in range(3):   # weights (F, 3): each corner's angle x its face normal's component c
        acc_pos[:, c] = np.bincount(cpos, weights=scale_rows(ang, fn[:, c]).ravel(), minlength=n_pos)
    la = norm(acc_pos)[:, None]
    unit_pos = divide_rows(acc_pos, la[:, 0])
    # a position is "smooth" when every face normal there is within half the crease angle of the mean direction
    # (less a margin far above the rounding of these dot products); its corners all accept every other corner
    half = math.radians(crease_angle) / 2 - 1e-7
    cos_half = math.cos(half) if half > 0 else 2.0           # 2: no position qualifies
    # Only some corners need their dot product: with u the position's mean direction and W its summed angles,
    # sum_j w_j (1 - n_j . u) = W - |acc| and every term is >= 0 (|n_j| <= 1), so a corner of angle w has
    # 1 - n . u <= (W - |acc|) / w; where w (1 - cos_half) exceeds that bound (plus a margin far above its
    # rounding) the corner is within half the crease angle. On a smooth mesh almost every corner is: the dot
    # products (three (F, 3) gathers) are formed for the few others only. Same classification as testing all.
    w = ang.ravel()
    total = np.bincount(cpos, weights=w, minlength=n_pos)
    slack = total - la[:, 0] + (1e-9 * total + 1e-300)
    cand = np.flatnonzero(w * (1.0 - cos_half) <= np.take(slack, cpos))
    far = np.einsum("ij,ij->i", np.take(fn, cand // 3, axis=0), np.take(unit_pos, cpos[cand], axis=0)) < cos_half
    rough_pos = np.zeros(n_pos, dtype=bool)
    rough_pos[cpos[cand[far]]] = True
    del cand, far, slack
    rough = np.flatnonzero(rough_pos[cpos])                   # corners of the other positions, ascending
    acc_rough = _pairwise_normals(rough, cpos, fn, ang, crease_angle)
    # split vertices whose corners got different normals: the output vertices in (source vertex, normal bits)
    # order, each corner mapped to its output vertex
    smooth_vertex = np.zeros(v.shape[0], dtype=bool)
    smooth_vertex[corner_vertex] = True
    smooth_vertex &= ~rough_pos[pos_of_vertex]
    sv = np.flatnonzero(smooth_vertex)                         # one output vertex each
    rv = corner_vertex[rough]
    key = np.concatenate([rv[:, None].astype(np.float64).view(np.int64), acc_rough.view(np.int64)], axis=1)
    ukey, first_idx, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inv = inv.ravel()
    urv = rv[first_idx]
    # output order: by source vertex, then (several normals of one vertex) by the normal's bits as np.unique sorts.
    # sv and urv both ascend and share no vertex (smooth / rough), so the order is their merge: each one's place is
    # its index plus the number of the other's vertices below it (no sort of all the output vertices)
    smooth_normals = np.take(unit_pos, pos_of_vertex[sv], axis=0)
    out_of_vertex = np.zeros(v.shape[0], dtype=np.int64)
    if not urv.size:                 # no vertex split: sv (ascending) is the output order
        out_of_vertex[sv] = np.arange(sv.size)
        return sv.astype(np.int64), np.take(out_of_vertex, corner_vertex).reshape(nf, 3), smooth_normals
    at_sv = np.arange(sv.size) + np.searchsorted(urv, sv)
    at_urv = np.arange(urv.size) + np.searchsorted(sv, urv)
    n_out = sv.size + urv.size
    src = np.empty(n_out, dtype=np.int64)
    src[at_sv], src[at_urv] = sv, urv
    normals = np.empty((n_out, 3))
    normals[at_sv], normals[at_urv] = smooth_normals, acc_rough[first_idx]
    out_of_vertex[sv] = at_sv
    out_faces = np.take(out_of_vertex, corner_vertex)
    out_faces[rough] = at_urv[inv]
    return src, out_faces.reshape(nf, 3), normals


def _face_normals_and_angles(v, f):
    """Unit face normals (zero for degenerate faces) and the interior angle at each corner: (F, 3), (F, 3).

    Three gathers of (F, 3) corner positions and three edge lengths (not a (F, 3, 3) copy and six norms); the
    values are bitwise those of the direct formulas (``a - b == -(b - a)`` exactly in IEEE arithmetic; the
    column-by-column ``cross``, ``norm`` and ``divide_rows`` of :mod:`pyrt.shaders.vec` are bitwise ``np.cross``,
    ``np.linalg.norm(axis=1)`` and the broadcast ``np.divide``, at less than half their time).
    """
    nf = f.shape[0]
    p = [np.take(v, f[:, k], axis=0) for k in range(3)]
    e = [p[(k + 1) % 3] - p[k] for k in range(3)]             # edge k: corner k -> corner k+1
    del p
    fn = cross(e[0], -e[2])
    fn = divide_rows(fn, norm(fn))
    length = [norm(x) for x in e]
    ang = np.zeros((nf, 3))
    for k in range(3):                                         # corner k: toward k+1 (e[k]) and k+2 (-e[k+2])
        nab = length[k] * length[(k + 2) % 3]
        c = np.divide(-np.einsum("ij,ij->i", e[k], e[(k + 2) % 3]), nab, out=np.zeros(nf), where=nab > 0)
        ang[:, k] = np.arccos(np.clip(c, -1.0, 1.0))
    return fn, ang


def _position_ids(v, groups=None):
    """Weld by exact position: ``(group id of each vertex (V,), number of groups)``; -0.0 and 0.0 are one position.
    With ``groups`` (V,) the label is a fourth key: equal positions of different groups stay apart.

    Sorted by one 64-bit hash of the three coordinates' bits (one argsort instead of a three-key lexsort); if two
    different positions share a hash (never seen, but possible), by the three keys instead. When every hash is
    distinct (one sort of the hashes, ~0.4x the argsort's time) every vertex is its own position: ``arange(V)``.
    """
    bits = (v + 0.0).view(np.int64)                            # + 0.0 turns -0.0 into 0.0; no NaN here (validated)
    if groups is not None:
        bits = np.concatenate([bits, np.asarray(groups, dtype=np.int64).reshape(-1, 1)], axis=1)
    ub = bits.view(np.uint64)
    h = _mix64(ub[:, 0])
    for k in range(1, bits.shape[1]):
        h = _mix64(h ^ ub[:, k])
    h = h.view(np.int64)
    sh = np.sort(h)
    if not np.any(sh[1:] == sh[:-1]):        # distinct hashes, so distinct positions (indexed meshes): no argsort
        return np.arange(v.shape[0]), v.shape[0]
    order = np.argsort(h, kind="stable")
    sb = np.take(bits, order, axis=0)
    new = np.ones(order.size, dtype=bool)
    new[1:] = np.any(sb[1:] != sb[:-1], axis=1)
    sh = h[order]
    if np.any(new[1:] & (sh[1:] == sh[:-1])):                 # a hash collision: group by the coordinates
        order = np.lexsort(tuple(bits[:, k] for k in reversed(range(bits.shape[1]))))
        sb = np.take(bits, order, axis=0)
        new[1:] = np.any(sb[1:] != sb[:-1], axis=1)
    gid = np.empty(order.size, dtype=np.int64)
    gid[order] = np.cumsum(new) - 1
    return gid, int(new.sum())


def _mix64(z):
    """SplitMix64's finaliser (Steele et al. 2014) on uint64 (a new array): every input bit reaches every output bit.

    Coordinates read from float32 files have 29 zero low bits in float64; a plain multiply-add of them keeps those
    zeros (a 35-bit hash: measured, equal hashes of different positions on the 2.6 M vertices of tools/big_mesh.py,
    so the slow three-key sort ran). Mixed, such collisions are as rare as 64-bit chance allows.
    """
    z = z ^ (z >> np.uint64(30))
    z *= np.uint64(0xBF58476D1CE4E5B9)
    z ^= z >> np.uint64(27)
    z *= np.uint64(0x94D049BB133111EB)
    z ^= z >> np.uint64(31)
    return z


def _pairwise_normals(corners, cpos, fn, ang, crease_angle):
    """For each corner of ``corners`` (ascending), the unit sum of ``angle x normal`` over the corners at its
    position whose face normal is within the crease angle of its own face's (itself included), in corner order."""
    n = corners.size
    if n == 0:
        return np.zeros((0, 3))
    pos = cpos[corners]
    order = np.argsort(pos, kind="stable")                    # by position, then corner (``corners`` ascends)
    sorted_pos = pos[order]
    starts = np.flatnonzero(np.r_[True, sorted_pos[1:] != sorted_pos[:-1]])
    counts = np.diff(np.r_[starts, sorted_pos.size])
    group_of_sorted = np.repeat(np.arange(starts.size), counts)
    # every (corner i, corner j) pair sharing a position; i in sorted order, j over its group
    cnt_i = counts[group_of_sorted]
    total = int(np.sum(cnt_i))
    rep_i = np.repeat(np.arange(n), cnt_i)
    first = np.repeat(np.cumsum(cnt_i) - cnt_i, cnt_i)
    j_sorted = starts[group_of_sorted][rep_i] + (np.arange(total) - first)
    ci = order[rep_i]                                          # local indices into ``corners``
    cj = order[j_sorted]
    fi, fj = corners[ci] // 3, corners[cj] // 3
    cos_lim = math.cos(math.radians(crease_angle))
    ok = np.einsum("ij,ij->i", fn[fi], fn[fj]) >= cos_lim - 1e-12
    ok |= fi == fj
    w = ang.ravel()[corners[cj]] * ok
    acc = np.zeros((n, 3))
    for c in range(3):
        acc[:, c] = np.bincount(ci, weights=w * fn[fj, c], minlength=n)
    la = np.linalg.norm(acc, axis=1, keepdims=True)
    return np.divide(acc, la, out=np.zeros_like(acc), where=la > 0)


def _crease_by_edges(vertices, faces, crease_angle):
    import trimesh  # deferred (pyrt.core.transforms)
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
