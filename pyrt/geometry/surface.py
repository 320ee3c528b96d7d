"""From Embree hits to surface data.

:class:`GeometryTable` concatenates every mesh of a scene into flat float64 arrays (world-space
vertices, per-vertex shading normals and UVs, per-face material and flags), so that surface data
for a batch of hits on many meshes is built with a few fancy-indexing operations and no Python
loop over meshes.

:func:`surface_from_hits` turns closest hits into a :class:`SurfaceBatch`: the hit point is rebuilt
from the triangle's vertices and the barycentrics in float64 (``(1-u-v) v0 + u v1 + v v2``, not
``o + t d``, which carries the error of ``t`` times the distance to the camera); the geometric normal
is recomputed in float64 and turned toward the viewer; the shading normal is interpolated from vertex
normals (smooth shading) or equals the geometric one (flat shading); UVs are interpolated; and when
the rays carry differentials the UV footprint (du/dx, dv/dx, du/dy, dv/dy) is computed as in pbrt
(the offset rays are intersected with the tangent plane; the offsets are expressed in barycentric
derivatives, which give the UV and normal derivatives without needing a UV parameterisation).
"""
from __future__ import annotations

import numpy as np

from pyrt.geometry.offsets import terminator_lift
from pyrt.geometry.uvsets import combine_rows as _combine, concat_uv_set, interpolate_uv, uv_set_at_hits, uv_tangents
from pyrt.shaders.vec import coordinate_frame, cross, dot, max_component, normalize, put_rows, scale_rows, take_rows, to_local


def _vertex_tangent_frames(m):
    """(V, 6) ``[t, w (n x t)]`` of a :class:`MeshData`'s vertex tangents (zeros without tangents or normals, and
    where the tangent is zero)."""
    out = np.zeros((m.vertices.shape[0], 6))
    if m.tangents is None or m.normals is None:
        return out
    t = m.tangents[:, :3]
    out[:, :3] = t
    out[:, 3:] = scale_rows(cross(m.normals, t), m.tangents[:, 3])
    return out


def _joined(arrays):
    """The arrays concatenated along axis 0; a single one as it is (no copy)."""
    return arrays[0] if len(arrays) == 1 else np.concatenate(arrays)


class GeometryTable:
    """All meshes of a scene concatenated (float64), indexed by (mesh id, triangle id). A single mesh's arrays are
    used as they are; with several, each mesh's arrays become views of its rows of the joined ones (one copy of the
    geometry in memory, the same values).

    ``shading_normal_fallback`` (default True): :func:`surface_from_hits` replaces an interpolated
    normal facing away from the viewer by the geometric normal; False keeps it (such hits shade
    black, as in pbrt-v4 and Mitsuba 3).
    """

    def __init__(self, meshes, *, shading_normal_fallback=True):
        self.meshes = list(meshes)
        #: Replace back-facing interpolated normals by the geometric normal (see the class docstring).
        self.shading_normal_fallback = bool(shading_normal_fallback)
        nv = [m.vertices.shape[0] for m in self.meshes]
        nf = [m.faces.shape[0] for m in self.meshes]
        self.vertex_offset = np.concatenate([[0], np.cumsum(nv)[:-1]]).astype(np.int64)
        self.face_offset = np.concatenate([[0], np.cumsum(nf)[:-1]]).astype(np.int64)
        # one mesh's arrays are used as they are (concatenating a single array copies it); nothing writes into them
        self.vertices = _joined([m.vertices for m in self.meshes])
        self.vertices_object = _joined([m.vertices_object for m in self.meshes])
        self.faces = _joined([m.faces + off if off else m.faces for m, off in zip(self.meshes, self.vertex_offset)
                              ]).astype(np.int64, copy=False)
        self.face_mesh = np.repeat(np.arange(len(self.meshes)), nf) if len(nf) > 1 else np.zeros(nf[0], np.int64)
        self.face_material = np.repeat([m.material_id for m in self.meshes], nf).astype(np.int64)
        smooth = [m.smooth and m.normals is not None for m in self.meshes]
        self.face_smooth = np.repeat(smooth, nf)
        self.normals = _joined([m.normals if m.normals is not None else np.zeros_like(m.vertices)
                                for m in self.meshes])
        self.face_has_uv = np.repeat([m.uv is not None for m in self.meshes], nf)
        self.uv = _joined([m.uv if m.uv is not None else np.zeros((m.vertices.shape[0], 2)) for m in self.meshes])
        if len(self.meshes) > 1:
            self._share_rows(nv, nf)
        self._uv_tables = {}
        #: (V, 6) per vertex: the unit world tangent and the bitangent ``w (n x t)`` of meshes with vertex tangents
        #: (:meth:`SurfaceBatch.shading_tangents`), zeros elsewhere; None when no mesh has them
        self.tangent_frames = None
        if any(m.tangents is not None for m in self.meshes):
            self.tangent_frames = np.concatenate([_vertex_tangent_frames(m) for m in self.meshes])
        self.any_smooth = bool(np.any(smooth))
        self.any_uv = bool(np.any(self.face_has_uv))
        # per-face bounds for ray offsets (pyrt.geometry.offsets.local_bound): the largest extent of the triangle's
        # bounding box (>= max_i ||v_i - p||_inf for any p on it) and the component-wise max |v_i|
        # (>= sum_i b_i |v_i| for any p on it)
        # (three (F, 3) gathers and elementwise extrema: the same values as reductions over a (F, 3, 3) copy, at a
        # fraction of the time and memory on multi-million-triangle meshes)
        p0, p1, p2 = (take_rows(self.vertices, self.faces[:, k]) for k in range(3))
        self.face_normals = normalize(cross(p1 - p0, p2 - p0))
        self.face_extent = max_component(np.maximum(np.maximum(p0, p1), p2) - np.minimum(np.minimum(p0, p1), p2))
        self.face_absmax = np.maximum(np.maximum(np.abs(p0), np.abs(p1)), np.abs(p2))

    def _share_rows(self, nv, nf):
        """Point every mesh's vertex arrays (and the first mesh's faces) at its rows of the joined arrays, which hold
        the same values: the scene keeps one copy of its geometry, not two (a model and the previewer's ground:
        0.3 GB of the 5.24 M-triangle mesh of tools/big_mesh.py)."""
        for m, vo, fo, n_v, n_f in zip(self.meshes, self.vertex_offset, self.face_offset, nv, nf):
            rows = slice(int(vo), int(vo) + n_v)
            m.vertices = self.vertices[rows]
            m.vertices_object = self.vertices_object[rows]
            if m.normals is not None:
                m.normals = self.normals[rows]
            if m.uv is not None:
                m.uv = self.uv[rows]
            if vo == 0:
                m.faces = self.faces[int(fo):int(fo) + n_f]

    def uv_table(self, k):
        """UV set ``k`` of every vertex, (V, 2) float64 (set 0: :attr:`uv`; zeros for meshes without set ``k``), or
        None when no mesh has it; built on the first request and kept (:mod:`pyrt.geometry.uvsets`)."""
        if k == 0:
            return self.uv
        if k not in self._uv_tables:
            self._uv_tables[k] = concat_uv_set(self.meshes, k)
        return self._uv_tables[k]


class SurfaceBatch:
    """Surface data at N hits (float64 unless noted). See the module docstring for the fields.

    :meth:`subset` returns a lazy view: a field is gathered (``base.field[idx]``) the first time it is
    read and then cached, so restricting a batch to the hits of one material or one light costs only
    the fields a kernel actually uses.
    """

    FIELDS = ("p", "p_object", "ng", "ns", "front", "wo", "uv", "dpdu", "dpdv", "duvdx", "duvdy", "dpdx", "dpdy",
              "dndx", "dndy", "mesh_id", "prim_id", "face", "material_id", "bary", "t", "p_error",
              "frame_s", "frame_t", "tri_v", "tri_n", "smooth", "tri_extent", "tri_absmax", "n_vertex", "p_lift",
              "ns_unmapped", "dbary", "vtangent")
    #: ``ns_unmapped``: the shading normals before :func:`pyrt.textures.apply_normal_maps` perturbed them (None
    #: when no normal map was applied; a clear coat's own frame starts from it)
    #: ``vtangent``: (N, 6) the interpolated vertex tangent and bitangent (``[t, b]``, not unit) of meshes with vertex
    #: tangents, zeros on faces without; None when no mesh of the scene has them (:meth:`shading_tangents`)
    #: ``dbary``: (N, 4) barycentric derivatives (db1/dx, db2/dx, db1/dy, db2/dy) from the ray differentials
    #: (zeros without them): the footprints of every UV set (:meth:`uv_set`)

    def __init__(self, lazy=None, **kwargs):
        """``lazy`` maps field names to a function computing a dict of fields on first access."""
        unknown = set(kwargs) - set(self.FIELDS)
        if unknown:
            raise TypeError(f"SurfaceBatch: unknown fields {sorted(unknown)}")
        self.__dict__["_lazy"] = dict(lazy or {})
        for name in self.FIELDS:
            if name in kwargs or name not in self._lazy:
                self.__dict__[name] = kwargs.get(name)
        if "frame_s" not in kwargs and self.ns is not None:
            # the tangent frame is built on first use (__getattr__): kernels on the world-space cosine path
            # never read it. (Not a lazy closure over self: that would be a reference cycle keeping every
            # batch's arrays alive until the cyclic garbage collector runs.)
            self.__dict__.pop("frame_s", None)
            self.__dict__.pop("frame_t", None)

    def __getattr__(self, name):
        # only called for fields not computed yet: evaluate their lazy group once
        lazy = self.__dict__.get("_lazy", {})
        if name in lazy:
            for k, v in lazy[name]().items():
                self.__dict__[k] = v
                lazy.pop(k, None)
            return self.__dict__[name]
        if name in ("frame_s", "frame_t") and "ns" in self.__dict__:
            self.__dict__["frame_s"], self.__dict__["frame_t"] = coordinate_frame(self.ns)
            return self.__dict__[name]
        raise AttributeError(name)

    @property
    def n_hits(self):
        return self.p.shape[0]

    def base_rows(self):
        """``(batch, rows)``: the batch this one's fields come from and their rows in it (a view of a view is a
        view of the first batch): ``(self, slice(0, n_hits))`` for a batch, its base and indices for a view
        (:meth:`subset`). What per-row caches shared by all views key on (:func:`pyrt.geometry.memo.row_memo`)."""
        return self, slice(0, self.n_hits)

    def subset(self, idx):
        """The batch restricted to ``idx`` (an index array, a boolean mask or a ``slice(lo, hi)``), as a lazy view.

        A slice (contiguous rows, e.g. the hits of one material once they are ordered by material) makes
        every field of the view a NumPy view of the batch's (no copy); an index array gathers each field on
        first read. Fields of a view are read-only by convention (nothing writes into a batch's fields).
        Views of one batch share its per-row memo (:func:`pyrt.geometry.memo.row_memo`): what a per-hit kernel
        computed on one view (the materials' texture lookups) is gathered for another instead of computed again.
        """
        if isinstance(idx, slice):
            lo, hi, step = idx.indices(self.n_hits)
            if step != 1:
                raise ValueError(f"SurfaceBatch.subset: a slice must have step 1, got {idx}")
            idx = slice(lo, max(lo, hi))
        else:
            idx = np.asarray(idx)
            if idx.dtype == bool:
                idx = np.flatnonzero(idx)
        return _SurfaceSubset(self, idx)

    def uv_set(self, k):
        """``(uv, duvdx, duvdy)`` of UV set ``k`` at the hits, each (N, 2) float64: set 0 is the fields ``uv``,
        ``duvdx``, ``duvdy``; set ``k`` >= 1 (glTF ``TEXCOORD_k``) is interpolated on first request and kept,
        zeros on meshes without it. A batch built from fields alone (no geometry) has only set 0, returned
        for every ``k``."""
        return (self.uv, self.duvdx, self.duvdy) if k == 0 else self._uv_set_values(k, "uv")

    def uv_tangents(self, k):
        """``(dpdu, dpdv)`` (N, 3) of UV set ``k`` (normal maps read in that set): set 0 is the fields ``dpdu``,
        ``dpdv``; otherwise as :meth:`uv_set`."""
        return (self.dpdu, self.dpdv) if k == 0 else self._uv_set_values(k, "tangents")

    def shading_tangents(self, k):
        """``(t, b)`` (N, 3): the tangent frame a normal map or an anisotropic lobe read in UV set ``k`` is built
        from (:func:`pyrt.shaders.textures.tangent_frame`: ``t`` made orthogonal to the shading normal, the
        bitangent's side from ``b``). On meshes with vertex tangents (glTF ``TANGENT``, or generated from the UVs by
        :mod:`pyrt.geometry.tangents`) their interpolation, as glTF asks (smooth across triangles, their
        handedness); elsewhere :meth:`uv_tangents` (the triangle's
        ``dpdu``, ``dpdv``: constant per triangle)."""
        vt = self.vtangent
        if vt is None:
            return self.uv_tangents(k)
        has = np.any(vt[:, :3] != 0.0, axis=1)
        if has.all():                   # the UV tangents are not needed (nor computed)
            return vt[:, :3], vt[:, 3:]
        t, b = self.uv_tangents(k)
        if not has.any():
            return t, b
        return np.where(has[:, None], vt[:, :3], t), np.where(has[:, None], vt[:, 3:], b)

    def _uv_set_values(self, k, what):
        cache = self.__dict__.setdefault("_uv_sets", {})
        if (k, what) not in cache:
            cache[(k, what)] = self._compute_uv_set(k, what)
        return cache[(k, what)]

    def _compute_uv_set(self, k, what):
        fn = self.__dict__.get("_uv_set_fn")
        if fn is None:      # built from fields: one UV set
            return (self.uv, self.duvdx, self.duvdy) if what == "uv" else (self.dpdu, self.dpdv)
        return fn(k, what, self)

    def set_shading_normal(self, ns):
        """Replace the shading normals (unit, (N, 3)) and rebuild the local frame."""
        self.ns = ns
        self.frame_s, self.frame_t = coordinate_frame(ns)

    def light_side(self, wi):
        """True where light arriving from ``wi`` (N, 3) can reach the side of the surface seen by ``wo``.

        ``ng . wi > 0``; on faces with interpolated vertex normals also where the interpolated vertex
        normal (``n_vertex``, before any normal map) faces ``wi``: the shadow-terminator zone of a
        smooth-shaded low-poly mesh, where the shadow ray (from the origin lifted by
        :func:`pyrt.geometry.offsets.terminator_point`) decides instead of the flat facet.
        """
        lit = dot(wi, self.ng) > 0
        if self.n_vertex is not None:
            # n_vertex equals ng on flat faces: one more dot over all lanes is cheaper than gathering
            # the smooth ones
            lit |= dot(wi, self.n_vertex) > 0
            return lit
        if self.smooth is not None:   # a batch from surface_from_hits without smooth faces
            return lit
        cached = self.__dict__.get("_n_interp")   # direction-independent: once per batch, not per light
        if cached is None:
            if self.tri_n is None:
                cached = (np.zeros(0, dtype=np.int64), None)
            else:
                cached = (np.arange(self.n_hits), np.einsum("ij,ijk->ik", self.bary, self.tri_n))
            self.__dict__["_n_interp"] = cached
        sm, n_interp = cached
        if sm.size:
            lit[sm] |= dot(take_rows(wi, sm), n_interp) > 0
        return lit

    def to_local(self, w):
        return to_local(w, self.frame_s, self.frame_t, self.ns)

    def to_world(self, w):
        """Local directions ``w`` (N, 3) (z = shading normal) in world space, column by column (the same sums
        as ``w[:, 0:1] * s + w[:, 1:2] * t + w[:, 2:3] * n``)."""
        s, t, n = self.frame_s, self.frame_t, self.ns
        out = np.empty(w.shape, dtype=np.result_type(w, s, t, n))
        tmp = np.empty(w.shape[0], dtype=out.dtype)
        for c in range(3):
            col = out[:, c]
            np.multiply(w[:, 0], s[:, c], out=col)
            col += np.multiply(w[:, 1], t[:, c], out=tmp)
            col += np.multiply(w[:, 2], n[:, c], out=tmp)
        return out


def compose_rows(outer, inner):
    """Rows of a batch for the rows ``inner`` of its view with rows ``outer`` (each an index array or a
    ``slice(lo, hi)``): ``outer[inner]``, kept a slice when both are."""
    if isinstance(outer, slice):
        if isinstance(inner, slice):
            return slice(outer.start + inner.start, outer.start + inner.stop)
        return inner + outer.start
    return outer[inner]


def take_view_rows(a, rows):
    """``a[rows]``: a view for a ``slice``, a row gather (:func:`pyrt.shaders.vec.take_rows`) for an index array."""
    return a[rows] if isinstance(rows, slice) else take_rows(a, rows)


class _SurfaceSubset(SurfaceBatch):
    """Lazy view of a :class:`SurfaceBatch` restricted to rows ``idx`` (an index array or a ``slice(lo, hi)``)."""

    def __init__(self, base, idx):  # noqa: D107 - deliberately does not call SurfaceBatch.__init__
        if isinstance(base, _SurfaceSubset):
            idx = compose_rows(base._idx, idx)
            base = base._base
        self.__dict__["_base"] = base
        self.__dict__["_idx"] = idx

    def __getattr__(self, name):
        # only called when the attribute is not cached in the instance dict yet
        if name in ("frame_s", "frame_t") and "frame_s" not in self._base.__dict__ and self.ns is not None:
            # the base has not built its frame: build the view's own (a per-row formula, the same rows a
            # gather would give) rather than the frame of every hit of the bounce (delta lobes of a few
            # mirror hits among many diffuse ones)
            self.__dict__["frame_s"], self.__dict__["frame_t"] = coordinate_frame(self.ns)
            return self.__dict__[name]
        if name in SurfaceBatch.FIELDS:
            val = getattr(self._base, name)
            val = None if val is None else take_view_rows(val, self._idx)
            self.__dict__[name] = val
            return val
        raise AttributeError(name)

    def base_rows(self):
        return self._base, self._idx

    def _compute_uv_set(self, k, what):
        # the base's set gathered (as every field of a view)
        return tuple(None if a is None else take_view_rows(a, self._idx) for a in self._base._uv_set_values(k, what))

    @property
    def n_hits(self):
        idx = self._idx
        return idx.stop - idx.start if isinstance(idx, slice) else idx.shape[0]


def _bary_solver(e1, e2):
    """``solve(dp) -> (a, b)``: the least-squares ``(a, b)`` with ``a e1 + b e2 ~= dp`` (rows of (N, 3); zero where
    singular), with the 2x2 normal matrix of ``e1, e2`` built once (the x and y differentials share it)."""
    a11 = dot(e1, e1)
    a12 = dot(e1, e2)
    a22 = dot(e2, e2)
    det = a11 * a22 - a12 * a12
    ok = np.abs(det) > 1e-300
    inv = np.divide(1.0, det, out=np.zeros_like(det), where=ok)

    def solve(dp):
        r1 = dot(e1, dp)
        r2 = dot(e2, dp)
        return (a22 * r1 - a12 * r2) * inv, (a11 * r2 - a12 * r1) * inv
    return solve


def surface_from_hits(geo: GeometryTable, hits, origins, dirs, differentials=None, mesh_ids=None):
    """Build a :class:`SurfaceBatch` for the rays that hit (``hits.hit`` must be all True).

    Parameters
    ----------
    geo : GeometryTable
    hits : pyrt.geometry.accel.Hits
        Restricted to hitting rays.
    origins, dirs : (N, 3) float64
        The rays (dirs unit length).
    differentials : tuple of four (N, 3) arrays or None
        ``(rx_o, rx_d, ry_o, ry_d)``: origins and directions of the x/y offset rays.
    mesh_ids : (N,) int64, optional
        The batch's ``mesh_id`` (default ``hits.mesh_id``): a table over some of a scene's meshes reports theirs.
    """
    n = hits.t.shape[0]
    face = geo.face_offset[hits.mesh_id] + hits.prim_id
    tri = take_rows(geo.faces, face)
    vtx = geo.vertices
    v0, v1, v2 = take_rows(vtx, tri[:, 0]), take_rows(vtx, tri[:, 1]), take_rows(vtx, tri[:, 2])
    b1, b2 = hits.u, hits.v
    b0 = 1.0 - b1 - b2
    bary = np.empty((n, 3))
    bary[:, 0], bary[:, 1], bary[:, 2] = b0, b1, b2
    p = scale_rows(v0, b0)                      # b0 v0 + b1 v1 + b2 v2, column by column (shaders.vec)
    tmp = scale_rows(v1, b1)
    p += tmp
    p += scale_rows(v2, b2, out=tmp)
    ng_out = take_rows(geo.face_normals, face)   # outward (winding) unit normal, precomputed per face
    wo = -dirs
    front = dot(ng_out, wo) >= 0
    sign = np.where(front, 1.0, -1.0)
    ng = scale_rows(ng_out, sign)

    # shading normal
    smooth = geo.face_smooth[face]
    ns = ng.copy()
    n_vertex = None
    nrm = geo.normals
    s = n_s = None
    if np.any(smooth):
        s = np.flatnonzero(smooth)
        ts, bs = take_rows(tri, s), take_rows(bary, s)
        n_s = (take_rows(nrm, ts[:, 0]), take_rows(nrm, ts[:, 1]), take_rows(nrm, ts[:, 2]))  # kept for p_lift
        ni = scale_rows(n_s[0], bs[:, 0])
        tmp = scale_rows(n_s[1], bs[:, 1])
        ni += tmp
        ni += scale_rows(n_s[2], bs[:, 2], out=tmp)
        ni = normalize(ni)
        scale_rows(ni, np.take(sign, s), out=ni)
        n_vertex = ng.copy()           # interpolated vertex normal before any fallback or normal map
        put_rows(n_vertex, s, ni)
        # An interpolated normal facing away from the viewer cannot shade anything: fall back to ng
        # (geo.shading_normal_fallback; off, only a zero normal falls back and the hit shades black).
        ng_s = take_rows(ng, s)
        bad = dot(ni, ni) == 0
        if geo.shading_normal_fallback:
            bad |= dot(ni, take_rows(wo, s)) <= 0
        if np.any(bad):
            b_ = np.flatnonzero(bad)
            put_rows(ni, b_, take_rows(ng_s, b_))
        put_rows(ns, s, ni)

    # Fields most kernels never read are computed on first access (model no more than needed).
    def uv_group():
        uvs = geo.uv
        return {"uv": interpolate_uv(take_rows(uvs, tri[:, 0]), take_rows(uvs, tri[:, 1]), take_rows(uvs, tri[:, 2]),
                                     b0, b1, b2)}

    def tangent_group():
        # dpdu / dpdv (tangent frames, anisotropic BRDFs, normal maps): most textures read only uv, not these
        uvs = geo.uv
        uv0 = take_rows(uvs, tri[:, 0])
        dpdu, dpdv = uv_tangents(v1 - v0, v2 - v0, take_rows(uvs, tri[:, 1]) - uv0, take_rows(uvs, tri[:, 2]) - uv0, ng)
        return {"dpdu": dpdu, "dpdv": dpdv}

    def object_group():
        vo = geo.vertices_object
        return {"p_object": b0[:, None] * take_rows(vo, tri[:, 0]) + b1[:, None] * take_rows(vo, tri[:, 1]) + b2[:, None] * take_rows(vo, tri[:, 2])}

    def differential_group():
        zeros3 = np.zeros((n, 3))
        if differentials is None:
            return {"dpdx": zeros3, "dpdy": zeros3, "dndx": zeros3, "dndy": zeros3,
                    "duvdx": np.zeros((n, 2)), "duvdy": np.zeros((n, 2)), "dbary": np.zeros((n, 4))}
        rx_o, rx_d, ry_o, ry_d = differentials
        e1, e2 = v1 - v0, v2 - v0
        d_plane = dot(ng, p)

        def offset_point(o, d):
            # q - p for the offset ray's point q = o + t d on the tangent plane, column by column
            denom = dot(ng, d)
            ok_ = np.abs(denom) > 1e-12
            tt = np.divide(d_plane - dot(ng, o), denom, out=np.zeros_like(denom), where=ok_)
            out = np.empty((n, 3))
            for c in range(3):
                col = out[:, c]
                np.multiply(tt, d[:, c], out=col)
                np.add(o[:, c], col, out=col)
                col -= p[:, c]
            if not ok_.all():
                out[~ok_] = 0.0
            return out

        dpdx = offset_point(rx_o, rx_d)
        dpdy = offset_point(ry_o, ry_d)
        solve = _bary_solver(e1, e2)
        bx1, bx2 = solve(dpdx)
        by1, by2 = solve(dpdy)
        uvs = geo.uv
        uv0 = take_rows(uvs, tri[:, 0])
        du1 = take_rows(uvs, tri[:, 1]) - uv0
        du2 = take_rows(uvs, tri[:, 2]) - uv0
        out = {"dpdx": dpdx, "dpdy": dpdy, "dndx": zeros3, "dndy": zeros3,
               "duvdx": _combine(bx1, du1, bx2, du2), "duvdy": _combine(by1, du1, by2, du2),
               "dbary": np.stack([bx1, bx2, by1, by2], axis=1)}
        if np.any(smooth):
            n0 = take_rows(nrm, tri[:, 0])
            dn1 = scale_rows(take_rows(nrm, tri[:, 1]) - n0, sign)
            dn2 = scale_rows(take_rows(nrm, tri[:, 2]) - n0, sign)
            flat = None if smooth.all() else np.flatnonzero(~smooth)
            for name, (w1, w2) in (("dndx", (bx1, bx2)), ("dndy", (by1, by2))):
                dn = _combine(w1, dn1, w2, dn2)
                if flat is not None:
                    dn[flat] = 0.0
                out[name] = dn
        return out

    def triangle_group():
        # the hit triangle's float32-exact vertices and its vertex normals turned to the ng side (zero on flat
        # faces), for ray offsets (pyrt.geometry.offsets: local error bounds, shadow-terminator lift)
        tri_n = np.zeros((n, 3, 3))
        if np.any(smooth):
            s = np.flatnonzero(smooth)
            put_rows(tri_n, s, np.take(nrm, take_rows(tri, s), axis=0) * sign[s, None, None])
        return {"tri_v": np.stack([v0, v1, v2], axis=1), "tri_n": tri_n}

    def lift_group():
        # Hanika's shadow-terminator lift (pyrt.geometry.offsets.terminator_point) from the vertex normals gathered
        # above for the shading normal: p' = p - sum_i b_i min(0, (p - v_i) . n_i) n_i, n_i on the ng side
        if s is None:
            return {"p_lift": p}
        all_smooth = s.size == n
        pick = (lambda a: a) if all_smooth else (lambda a: take_rows(a, s))
        lifted = terminator_lift(pick(p), [pick(v0), pick(v1), pick(v2)], n_s, bs, sign=pick(sign))
        if all_smooth:
            return {"p_lift": lifted}
        out = p.copy()
        put_rows(out, s, lifted)
        return {"p_lift": out}

    def vtangent_group():
        fr = geo.tangent_frames
        if fr is None:
            return {"vtangent": None}
        out = scale_rows(take_rows(fr, tri[:, 0]), b0)
        out += scale_rows(take_rows(fr, tri[:, 1]), b1)
        out += scale_rows(take_rows(fr, tri[:, 2]), b2)
        return {"vtangent": out}

    lazy = {"uv": uv_group, "vtangent": vtangent_group}
    lazy.update({k: tangent_group for k in ("dpdu", "dpdv")})
    lazy["p_lift"] = lift_group
    lazy.update({k: triangle_group for k in ("tri_v", "tri_n")})

    def error_group():
        return {"p_error": np.abs(b0)[:, None] * np.abs(v0) + np.abs(b1)[:, None] * np.abs(v1)
                + np.abs(b2)[:, None] * np.abs(v2)}
    lazy["p_error"] = error_group

    def bounds_group():
        return {"tri_extent": geo.face_extent[face], "tri_absmax": take_rows(geo.face_absmax, face)}
    lazy.update({k: bounds_group for k in ("tri_extent", "tri_absmax")})
    lazy["p_object"] = object_group
    lazy.update({k: differential_group for k in ("dpdx", "dpdy", "dndx", "dndy", "duvdx", "duvdy", "dbary")})
    surf = SurfaceBatch(lazy=lazy, p=p, ng=ng, ns=ns, front=front, wo=wo, smooth=smooth,
                        mesh_id=hits.mesh_id if mesh_ids is None else mesh_ids,
                        n_vertex=n_vertex,
                        prim_id=hits.prim_id, face=face, material_id=geo.face_material[face], bary=bary, t=hits.t)
    # UV sets k >= 1 on request (SurfaceBatch.uv_set; a function of the batch, not a closure over it: no cycle)
    surf.__dict__["_uv_set_fn"] = lambda k, what, batch: uv_set_at_hits(geo.uv_table(k), tri, batch, what)
    return surf
