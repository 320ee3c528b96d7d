"""Coverage: alpha cut-outs (MASK), straight-through transparency (BLEND) and back-face culling (single-sided
surfaces), for the camera and secondary rays of the wavefront loop and for shadow rays.

What a material declares (:class:`pyrt.materials.Material`; glTF's ``alphaMode``, ``alphaCutoff``,
``doubleSided``): ``alpha_mode``, ``opacity`` (the coverage alpha ``a``, a number or a 1-channel texture,
:meth:`Material.coverage`), ``alpha_cutoff`` and ``double_sided``. At a hit on such a material:

- **culled** (``double_sided=False``; not for dielectrics or transmitting materials, whose back faces are
  the way out of their volume): a hit on the back side (the winding normal faces away from the ray,
  ``SurfaceBatch.front`` False) does not exist for camera and secondary rays. Shadow rays are stopped by
  both sides: the flag says what the viewer sees of a surface (glTF's back-face culling), not whether it
  blocks light; a single-sided leaf lit from behind still casts its shadow.
- **mask**: the hit is skipped where ``a < alpha_cutoff`` (``a`` filtered at the ray's footprint, as the
  base colour is), for camera, secondary and shadow rays (a leaf texture's shadow has holes); elsewhere the
  surface is opaque.
- **blend**: coverage. ``a = 0`` skips the hit, ``a = 1`` is opaque; in between the ray is split in two
  records: the hit, shaded with weight ``a``, and a continuation through it with weight ``1 - a``. Both
  belong to the same bounce (transparency costs no depth), so the radiance is ``a L_surface + (1 - a)
  L_behind`` exactly, with no noise. A shadow ray crossing the surface is multiplied by ``1 - a``.

embreex has no intersection-filter callbacks, so skipped and continued rays are *re-traced* from the hit:
the origin is pushed to the far side by the integrator's offset strategy (as a refracted ray would be,
:mod:`pyrt.geometry.offsets`), the direction is kept, and ``t`` is still measured from the ray's original
origin (depth AOV, media). At most :data:`MAX_LAYERS` surfaces are skipped or split per ray and bounce; a ray
that meets yet another after that is dropped (radiance 0; a shadow ray counts as blocked). A continuation
whose throughput falls to the integrator's ``throughput_cutoff`` is dropped as a spawned ray would be.

Shadow rays (:func:`pyrt.integrators.shadows.transmittance` with ``coverage=``) first ask Embree's cheap
any-hit query; only those it reports blocked are re-traced as closest hits through the see-through surfaces
(mask texels below the cutoff: 1, others 0; blend ``1 - a``). Their opacity is read at the full-resolution
texture (shadow rays carry no footprint).

With nested dielectrics (:mod:`pyrt.integrators.media`) a ray's first surfaces are resolved here; surfaces
found behind a false (skipped) dielectric hit are checked for culling and cut-outs but a blend surface there
counts as opaque (no split).

Cost model: :meth:`CoverageTable.for_scene` is None when every material is opaque and double-sided; the
integrator then keeps its single closest-hit query per bounce and its occlusion queries (bit-identical
images), and shadow rays pay only when a material is ``"mask"`` or ``"blend"``. With culling alone (glTF's
default ``doubleSided`` false) the integrator keeps its hits-only query and :meth:`CoverageTable.cull_hits`
tests the winding normal of each hit and re-traces only the back-face hits.
"""
from __future__ import annotations

import numpy as np

from pyrt.geometry.accel import Hits
from pyrt.geometry.surface import surface_from_hits
from pyrt.materials.base import ALPHA_MODES
from pyrt.shaders.vec import dot, take_rows

#: surfaces one ray may skip or split per bounce (cut-out foliage, stacked decals) before it is dropped
MAX_LAYERS = 32
#: :attr:`CoverageTable.mode` of mask and blend materials
MODE_MASK, MODE_BLEND = ALPHA_MODES.index("mask"), ALPHA_MODES.index("blend")
_FIELDS = ("hit", "t", "mesh_id", "prim_id", "u", "v", "ng")


class CoverageTable:
    """Per-material coverage flags of a scene (index = material id).

    Parameters
    ----------
    materials : list of Material
    """

    def __init__(self, materials):
        self.materials = materials
        #: 0 opaque, 1 mask, 2 blend (indices into :data:`pyrt.materials.base.ALPHA_MODES`)
        self.mode = np.array([ALPHA_MODES.index(m.alpha_mode) for m in materials], dtype=np.int64)
        self.cutoff = np.array([float(m.alpha_cutoff) for m in materials])
        #: back faces culled for camera and secondary rays
        self.cull = np.array([m.culls_back_faces for m in materials], dtype=bool)
        #: shadow rays may pass (mask or blend)
        self.see_through = self.mode > 0
        #: hits on these materials need a look
        self.active = self.see_through | self.cull

    @classmethod
    def for_scene(cls, materials):
        """The table, or None when every material is opaque and double-sided (nothing to do)."""
        table = cls(materials)
        return table if np.any(table.active) else None

    @property
    def shadows(self):
        """True when shadow rays may pass some surface (a mask or blend material)."""
        return bool(np.any(self.see_through))

    def _opacity(self, surf, mat, lanes):
        """Coverage alpha (len(lanes),) at the hits ``lanes`` of ``surf`` (material ids ``mat[lanes]``)."""
        a = np.ones(lanes.size)
        for k in np.unique(mat[lanes]):
            sel = np.flatnonzero(mat[lanes] == k)
            a[sel] = self.materials[k].coverage(surf.subset(lanes[sel]))
        return a

    def shadow_factor(self, k, ctx):
        """Transmittance (N,) of see-through material ``k`` for shadow rays at the hits ``ctx``: mask 1 below
        the cutoff and 0 above, blend ``1 - a``."""
        return 1.0 - self.materials[k].seen_fraction(ctx)

    def cull_hits(self, geo, idx, hits, o, d, intersect_hits, respawn):
        """Culling only (no mask or blend material): the closest hits of the rays ``o, d`` with back faces of
        single-sided materials skipped, in the hits-only form of :meth:`pyrt.geometry.accel.Accel.intersect_hits`.

        Parameters
        ----------
        idx : (K,) int ndarray
            The rays that hit; ``hits`` their :class:`Hits`.
        intersect_hits : callable
            ``intersect_hits(o, d) -> (idx, hits)`` (the integrator's, for its statistics).
        respawn : callable
            As for :meth:`resolve`.

        Returns
        -------
        idx, hits, dropped
            The rays that still hit something and their hits (``t`` from the original origins), and the rays
            dropped after :data:`MAX_LAYERS` culled faces (the caller zeroes their throughput).
        """
        idx = np.asarray(idx)
        cur = {f: np.array(getattr(hits, f), copy=True) for f in _FIELDS}
        keep = np.ones(idx.size, dtype=bool)
        lanes = np.arange(idx.size)
        dropped = idx[:0]
        for layer in range(MAX_LAYERS + 1):
            face = geo.face_offset[cur["mesh_id"][lanes]] + cur["prim_id"][lanes]
            ray = idx[lanes]
            back = dot(take_rows(geo.face_normals, face), take_rows(d, ray)) > 0
            lanes = lanes[back & self.cull[geo.face_material[face]]]
            if lanes.size == 0:
                break
            if layer == MAX_LAYERS:
                keep[lanes] = False
                dropped = idx[lanes]
                break
            ray = idx[lanes]
            sub = Hits(**{f: cur[f][lanes] for f in _FIELDS})
            dl = take_rows(d, ray)
            origins = respawn(surface_from_hits(geo, sub, take_rows(o, ray), dl), dl)
            k, nh = intersect_hits(origins, dl)
            keep[lanes] = False
            lanes = lanes[k]
            keep[lanes] = True
            t_base = dot(take_rows(origins, k) - take_rows(o, idx[lanes]), take_rows(dl, k))
            for f in _FIELDS:
                cur[f][lanes] = getattr(nh, f)
            cur["t"][lanes] = t_base + nh.t
        sel = np.flatnonzero(keep)
        return idx[sel], Hits(**{f: cur[f][sel] for f in _FIELDS}), dropped

    def resolve(self, geo, hits, o, d, diffs, intersect, respawn, *, thr_max=None, cutoff=0.0, split=True):
        """The surfaces rays ``o + t d`` see, with cut-outs and culled faces skipped and blend surfaces split.

        Parameters
        ----------
        geo : pyrt.geometry.GeometryTable
        hits : pyrt.geometry.accel.Hits
            Closest hits of the N rays (all rays, ``hit`` False on a miss).
        o, d : (N, 3) float64 ndarray
            Origins and unit directions.
        diffs : tuple of four (N, 3) arrays or None
            Ray differentials (texture footprints of the opacity).
        intersect : callable
            ``intersect(o, d) -> Hits`` (all rays; the integrator's, for its statistics).
        respawn : callable
            ``respawn(surf, d) -> origins`` past the hits of the :class:`SurfaceBatch` ``surf`` along ``d``.
        thr_max : (N,) float ndarray, optional
            Max-channel throughput of each ray: a blend continuation whose ``thr_max * weight <= cutoff`` is
            dropped.
        split : bool
            False: blend surfaces with ``0 < a`` count as opaque (weight 1).

        Returns
        -------
        parent : (M,) int64 ndarray
            The ray each record belongs to; records ``0 .. N-1`` are the rays themselves in order (their
            nearest surface that is kept, or a miss), records from ``N`` on are blend continuations.
        weight : (M,) float64 ndarray
            The record's share: products of ``a`` and ``1 - a`` (0 for a ray dropped after :data:`MAX_LAYERS`).
        hits : Hits
            M records, ``t`` measured from the original origins.
        """
        n = o.shape[0]
        cur = {f: np.array(getattr(hits, f), copy=True) for f in _FIELDS}
        parent = np.arange(n)
        weight = np.ones(n)
        todo = np.arange(n)
        for layer in range(MAX_LAYERS + 1):
            rec = todo[cur["hit"][todo]]
            if rec.size == 0:
                break
            mat = geo.face_material[geo.face_offset[cur["mesh_id"][rec]] + cur["prim_id"][rec]]
            active = self.active[mat]
            rec, mat = rec[active], mat[active]
            if rec.size == 0:
                break
            if layer == MAX_LAYERS:         # still finding see-through surfaces: dropped
                cur["hit"][rec] = False
                weight[rec] = 0.0
                break
            # back faces from the winding normal alone (no surface batch for hits that are simply kept)
            face = geo.face_offset[cur["mesh_id"][rec]] + cur["prim_id"][rec]
            back = dot(take_rows(geo.face_normals, face), take_rows(d, parent[rec])) > 0
            skip = self.cull[mat] & back
            mode = self.mode[mat]
            look = (mode > 0) & ~skip
            work = look | skip
            if not np.any(work):
                break
            rec, mat, skip, mode, look = rec[work], mat[work], skip[work], mode[work], np.flatnonzero(look[work])
            p = parent[rec]
            dsub = None if diffs is None else tuple(take_rows(x, p) for x in diffs)
            surf = surface_from_hits(geo, Hits(**{f: cur[f][rec] for f in _FIELDS}), take_rows(o, p),
                                     take_rows(d, p), dsub)
            a = np.ones(rec.size)
            if look.size:
                a[look] = self._opacity(surf, mat, look)
            skip |= ((mode == MODE_MASK) & (a < self.cutoff[mat])) | ((mode == MODE_BLEND) & (a <= 0.0))
            through = np.flatnonzero(skip)
            if split:
                si = np.flatnonzero((mode == MODE_BLEND) & (a > 0.0) & (a < 1.0))
                if si.size:
                    w_cont = weight[rec[si]] * (1.0 - a[si])
                    weight[rec[si]] *= a[si]
                    if thr_max is not None:
                        alive = thr_max[p[si]] * w_cont > cutoff
                        si, w_cont = si[alive], w_cont[alive]
                    if si.size:                   # new records, copies of the split ones, continue past the hit
                        new = np.arange(parent.size, parent.size + si.size)
                        parent = np.concatenate([parent, p[si]])
                        weight = np.concatenate([weight, w_cont])
                        for f in _FIELDS:
                            cur[f] = np.concatenate([cur[f], cur[f][rec[si]]])
                        rec = np.concatenate([rec, new])
                        through = np.concatenate([through, np.arange(surf.n_hits, surf.n_hits + si.size)])
                        lanes = np.concatenate([np.arange(surf.n_hits), si])
                        surf = surf.subset(lanes)
            if through.size == 0:
                break
            cont = rec[through]
            dc = take_rows(d, parent[cont])
            origins = respawn(surf.subset(through), dc)
            nh = intersect(origins, dc)
            t_base = dot(origins - take_rows(o, parent[cont]), dc)   # t keeps counting from the first origin
            for f in _FIELDS:
                cur[f][cont] = getattr(nh, f)
            cur["t"][cont] = np.where(nh.hit, t_base + nh.t, np.inf)
            todo = cont
        return parent, weight, Hits(**cur)
