"""Whitted / direct-lighting integrator, wavefront style.

The image is processed in chunks of pixels (bounded memory: a chunk holds at most
``chunk_samples`` camera samples). For each chunk, one batch of rays per bounce depth:

1. closest hits for the whole batch (:meth:`pyrt.geometry.accel.Accel.intersect`);
2. misses add ``throughput * background`` (or the environment's radiance);
3. hits become a :class:`pyrt.geometry.SurfaceBatch`; materials are evaluated once per material
   *type* on the hits that use them (``np.flatnonzero(material_id == k)``);
4. emission, direct light from every light (shadow rays through :meth:`Accel.occluded`, only where
   the light can contribute: in front of the surface, inside the cone, non-zero BSDF) and the
   optional constant ambient term are added for materials with a non-delta lobe;
5. delta lobes (mirror reflection; glass reflection and Fresnel-weighted refraction with total
   internal reflection) spawn the next batch with multiplied throughput; rays whose throughput
   falls below ``throughput_cutoff`` (max over RGB) or that reach ``max_depth`` are dropped.

This module knows nothing about Embree; it asks :class:`pyrt.geometry.accel.Accel` for hits and occlusion.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import functools
import math
import time
import warnings

import numpy as np

from pyrt.geometry import offsets
from pyrt.geometry.accel import Accel, T_INFINITE
from pyrt.geometry.surface import refract_differentials, reflect_differentials, surface_from_hits
from pyrt.integrators import gouraud
from pyrt.integrators.media import NestedMedia
from pyrt.materials.library import CosineQuery
from pyrt.textures import apply_normal_maps
from pyrt.shaders.vec import dot, max_component, put_rows, take_rows, to_float32


@dataclass
class RenderStats:
    """Counters of one render (rays by kind, time), and optionally the traced rays themselves."""

    primary_rays: int = 0
    secondary_rays: int = 0
    shadow_rays: int = 0
    time_total: float = 0.0
    time_intersect: float = 0.0
    time_occluded: float = 0.0
    nonfinite_samples: int = 0
    recorded: list = field(default_factory=list)

    @property
    def rays(self):
        return self.primary_rays + self.secondary_rays + self.shadow_rays


class PreparedScene:
    """A scene with its Embree acceleration structure and flat geometry table built once."""

    def __init__(self, scene, *, threads=None):
        self.scene = scene
        self.geo = scene.geometry_table()
        self.accel = Accel(threads=threads)
        for m in self.geo.meshes:
            self.accel.add_mesh(m.vertices, m.faces)
        self.accel.commit()
        mats = scene.materials
        self.has_delta = np.array([m.has_delta for m in mats], dtype=bool)
        self.has_diffuse = np.array([m.has_diffuse for m in mats], dtype=bool)
        # nested dielectrics (pyrt.integrators.media): per-ray interface stacks only when the scene needs them
        self.media = NestedMedia.for_scene(mats)
        # faces shaded per vertex (pyrt.integrators.gouraud), None when no mesh asks for it
        self.face_gouraud = gouraud.face_mask(self.geo, getattr(scene, "gouraud_meshes", ()))
        self.needs_differentials = any(_uses_texture(m) for m in mats)
        #: materials whose emission() can be non-zero (the rest skip the emission pass)
        self.emits = np.array([_may_emit(m) for m in mats], dtype=bool)
        # materials with a tangent-space normal map (attribute ``normal_map``, see pyrt.textures)
        self.has_normal_maps = any(getattr(m, "normal_map", None) is not None for m in mats)

    def close(self):
        self.accel.close()


def _may_emit(material):
    """False only when the material certainly emits nothing (the base class or a Lambert with zero emission)."""
    from pyrt.materials.library import Lambert, Material
    if type(material).emission is Material.emission:
        return False
    if type(material).emission is Lambert.emission:
        e = material.emission_value
        return hasattr(e, "evaluate") or bool(np.any(np.asarray(e) > 0))
    return True


def _uses_texture(material):
    return any(hasattr(v, "evaluate") for v in vars(material).values())


class _Group:
    """The hits of one material inside a :class:`BSDFBatch` (lazy local ``wo`` and ``n.wo``)."""

    __slots__ = ("idx", "ctx", "_wo_l", "_cos_o")

    def __init__(self, idx, ctx):
        self.idx, self.ctx, self._wo_l, self._cos_o = idx, ctx, None, None

    @property
    def wo_l(self):
        if self._wo_l is None:
            self._wo_l = self.ctx.to_local(self.ctx.wo)
        return self._wo_l

    @property
    def cos_o(self):
        if self._cos_o is None:
            self._cos_o = self._wo_l[:, 2] if self._wo_l is not None else dot(self.ctx.wo, self.ctx.ns)
        return self._cos_o


def _has_cosine_path(material):
    """True when the material's ``f_cos_cosines`` fast path belongs to the same class as its ``f_cos``
    (a subclass that overrides only ``f_cos`` must not inherit its parent's fast path)."""
    return _class_has_cosine_path(type(material))


@functools.lru_cache(maxsize=None)
def _class_has_cosine_path(cls):
    """:func:`_has_cosine_path` per class, decided once (not per bounce and chunk)."""
    if getattr(cls, "f_cos_cosines", None) is None:
        return False
    owner = lambda name: next(c for c in cls.__mro__ if name in c.__dict__)  # noqa: E731
    return owner("f_cos") is owner("f_cos_cosines")


class BSDFBatch:
    """The BSDFs of all hits of a :class:`SurfaceBatch`, dispatched per material type.

    Each material's hits form a persistent group context (built once per bounce), so texture lookups
    cached by :meth:`pyrt.materials.Material.param` are shared by all lights. Materials with the
    isotropic fast path (``f_cos_cosines``) are evaluated on the queried lanes from world-space
    cosines; for the others a query on most of a group evaluates the whole group in its local frame
    (inactive lanes are computed and discarded, cheaper than gathering every field) and a query on a
    small part of it gathers a lazy subset instead.
    """

    #: below this fraction of a group's hits, a query gathers a subset instead of evaluating the group
    GATHER_FRACTION = 0.35

    def __init__(self, surf, materials):
        self.surf = surf
        self.materials = materials
        self.mat_id = mat_id = surf.material_id
        self.groups = {}
        self.cosine_path = {}
        counts = np.bincount(mat_id)
        present = np.flatnonzero(counts)
        # Hits sorted by material (the integrator orders them so): each group is a contiguous range and a
        # query's sorted hit indices split into groups by two binary searches, no per-query partitioning.
        self.contiguous = mat_id.size < 2 or not np.any(mat_id[1:] < mat_id[:-1])
        self.pos = None if self.contiguous else np.zeros(mat_id.size, dtype=np.int64)  # position inside the group
        starts = np.concatenate([[0], np.cumsum(counts[present])]) if self.contiguous else None
        for j, k in enumerate(present):
            if self.contiguous:
                idx_k = np.arange(starts[j], starts[j + 1])
            else:
                idx_k = np.flatnonzero(mat_id == k)
                self.pos[idx_k] = np.arange(idx_k.size)
            self.groups[int(k)] = _Group(idx_k, surf.subset(idx_k))
            self.cosine_path[int(k)] = _has_cosine_path(materials[k])
        self.bounds = starts

    def _groups(self, idx):
        """Yield ``(material, sel, p, group)``: ``sel`` (slice or index array) picks the query entries of the
        group, ``p`` their positions inside it."""
        if self.contiguous and (idx.size < 2 or not np.any(idx[1:] <= idx[:-1])):   # strictly increasing
            b = np.searchsorted(idx, self.bounds)
            for j, (k, grp) in enumerate(self.groups.items()):
                lo, hi = int(b[j]), int(b[j + 1])
                if hi > lo:
                    yield k, slice(lo, hi), idx[lo:hi] - self.bounds[j], grp
            return
        pos = self.pos if self.pos is not None else self._positions()
        mids = self.mat_id[idx]
        for k in np.flatnonzero(np.bincount(mids)):
            sel = np.flatnonzero(mids == k)
            yield int(k), sel, pos[idx[sel]], self.groups[int(k)]

    def _positions(self):
        pos = np.zeros(self.mat_id.size, dtype=np.int64)
        for grp in self.groups.values():
            pos[grp.idx] = np.arange(grp.idx.size)
        self.pos = pos
        return pos

    @staticmethod
    def _take(a, sel, n):
        """``a[sel]`` for a slice (a view) or an index array (a gather; ``a`` itself if it selects all ``n``)."""
        if isinstance(sel, slice):
            return a[sel]
        return a if sel.size == n else take_rows(a, sel)

    def f_cos(self, idx, wi):
        """BSDF * cos(theta_i) at hits ``idx`` for world directions ``wi`` (k, 3)."""
        out = None
        for k, sel, p, grp in self._groups(idx):
            mat, ctx, n_k = self.materials[k], grp.ctx, grp.idx.size
            wi_s = self._take(wi, sel, idx.size)
            if self.cosine_path[k]:
                # all lanes, in order (p strictly increasing: always on the contiguous path)
                full = p.size == n_k and (isinstance(sel, slice) or not np.any(p[1:] <= p[:-1]))
                ns = ctx.ns if full else take_rows(ctx.ns, p)
                cos_o = grp.cos_o if full else np.take(grp.cos_o, p)
                val = mat.f_cos_cosines(CosineQuery(ctx, None if full else p, wi_s, dot(wi_s, ns), cos_o))
            elif p.size >= self.GATHER_FRACTION * n_k:
                w_full = ctx.ns.copy()          # harmless direction for lanes not queried
                put_rows(w_full, p, wi_s)
                val = take_rows(mat.f_cos(grp.wo_l, ctx.to_local(w_full), ctx), p)
            else:
                sub = ctx.subset(p)
                val = mat.f_cos(take_rows(grp.wo_l, p), sub.to_local(wi_s), sub)
            if p.size == idx.size:
                return np.asarray(val, dtype=np.float64)
            if out is None:
                out = np.zeros((idx.shape[0], 3))
            if isinstance(sel, slice):
                out[sel] = val
            else:
                put_rows(out, sel, val)
        return out if out is not None else np.zeros((idx.shape[0], 3))

    def sample(self, idx, u):
        """Sample the non-delta lobes at hits ``idx``: world ``wi``, weight f_cos/pdf, pdf."""
        wi = np.zeros((idx.shape[0], 3))
        weight = np.zeros((idx.shape[0], 3))
        pdf = np.zeros(idx.shape[0])
        for k, sel, p, grp in self._groups(idx):
            sub = grp.ctx.subset(p)
            w, wt, pd = self.materials[k].sample(grp.wo_l[p], u[sel], sub)
            wi[sel], weight[sel], pdf[sel] = sub.to_world(w), wt, pd
        return wi, weight, pdf

    def pdf(self, idx, wi):
        out = np.zeros(idx.shape[0])
        for k, sel, p, grp in self._groups(idx):
            sub = grp.ctx.subset(p)
            out[sel] = self.materials[k].pdf(grp.wo_l[p], sub.to_local(wi[sel]), sub)
        return out


def _scatter_add(acc, idx, vals, unique=False):
    """acc[idx] += vals with repeated indices (per RGB channel, via bincount); ``unique``: idx has none."""
    if unique:
        put_rows(acc, idx, take_rows(acc, idx) + vals)
        return
    n = acc.shape[0]
    for c in range(3):
        acc[:, c] += np.bincount(idx, weights=vals[:, c], minlength=n)


class Integrator:
    """Whitted integrator over a :class:`PreparedScene`.

    Parameters
    ----------
    max_depth : int
        Maximum number of specular bounces (0 = direct light only).
    throughput_cutoff : float
        Specular rays whose max-channel throughput falls below this are dropped.
    offset : str or callable
        Ray-origin offset strategy (see :mod:`pyrt.geometry.offsets`).
    record_rays : bool
        Keep every traced ray (float32 origins, dirs, tmax, kind) in ``stats.recorded`` for benchmarks.
    """

    def __init__(self, prepared, *, max_depth=8, throughput_cutoff=1e-4, offset=None, record_rays=False):
        if int(max_depth) != max_depth or max_depth < 0:
            raise ValueError(f"max_depth must be a non-negative integer, got {max_depth!r}")
        self.ps = prepared
        self.scene = prepared.scene
        self.max_depth = int(max_depth)
        self.throughput_cutoff = float(throughput_cutoff)
        self.offset = offsets.get_strategy(offset)
        self.record_rays = record_rays
        self.stats = RenderStats()

    # -- Embree calls with bookkeeping -------------------------------------------------------
    def _intersect(self, o, d, kind, hits_only=False):
        """Closest hits (:meth:`Accel.intersect`), or with ``hits_only`` ``(idx, hits restricted to idx)``
        (:meth:`Accel.intersect_hits`); counts the rays by ``kind`` and records them if asked."""
        t0 = time.perf_counter()
        h = self.ps.accel.intersect_hits(o, d) if hits_only else self.ps.accel.intersect(o, d)
        self.stats.time_intersect += time.perf_counter() - t0
        if kind == "primary":
            self.stats.primary_rays += o.shape[0]
        else:
            self.stats.secondary_rays += o.shape[0]
        if self.record_rays:
            self.stats.recorded.append(("intersect", o.astype(np.float32), d.astype(np.float32), None))
        return h

    def _occluded(self, o, d, tmax):
        t0 = time.perf_counter()
        occ = self.ps.accel.occluded(o, d, tmax)
        self.stats.time_occluded += time.perf_counter() - t0
        self.stats.shadow_rays += o.shape[0]
        if self.record_rays:
            self.stats.recorded.append(("occluded", o.astype(np.float32), d.astype(np.float32),
                                        np.minimum(tmax, T_INFINITE).astype(np.float32)))
        return occ

    def background(self, d, primary=False):
        """Radiance of missed rays: the environment (or the scene background colour). Camera rays
        (``primary``) see ``environment.background`` instead when ``environment.hide_background`` is set."""
        env = self.scene.environment
        if env is not None:
            if primary and getattr(env, "hide_background", False):
                return np.broadcast_to(env.background, d.shape)
            return env.radiance(d)
        return np.broadcast_to(self.scene.background, d.shape)

    # -- one chunk ---------------------------------------------------------------------------
    def render_samples(self, o, d, diffs, want_aovs=False, rng=None):
        """Radiance (N, 3) float64 for camera rays ``o, d`` (and AOVs of the first hit if asked)."""
        n = o.shape[0]
        L = np.zeros((n, 3))
        aovs = None
        if want_aovs:
            aovs = {"depth": np.full(n, np.inf), "normal": np.zeros((n, 3)), "albedo": np.zeros((n, 3))}
        rng = rng if rng is not None else np.random.default_rng(0)
        sample = np.arange(n)
        thr = np.ones((n, 3))
        materials = self.scene.materials
        lights = self.scene.lights
        ambient = self.scene.ambient
        use_diffs = diffs is not None and self.ps.needs_differentials
        media = self.ps.media
        stack = media.empty(n) if media is not None else None
        for depth in range(self.max_depth + 1):
            if o.shape[0] == 0:
                break
            kind = "primary" if depth == 0 else "secondary"
            if media is not None:  # nested dielectrics: continue through false hits; Beer-Lambert absorption
                hits = self._intersect(o, d, kind)
                hits, seg_t, stack = media.skip_false_hits(
                    self.ps.geo, hits, o, d, stack, lambda o2, d2: self._intersect(o2, d2, "secondary"),
                    lambda hs, o2, d2: self.offset(surface_from_hits(self.ps.geo, hs, o2, d2), d2))
                thr = thr * media.attenuation(stack, seg_t)
                h = np.flatnonzero(hits.hit)
                hsub = _subset_hits(hits, h)
            else:
                h, hsub = self._intersect(o, d, kind, hits_only=True)
            if h.size < o.shape[0]:
                miss = np.ones(o.shape[0], dtype=bool)
                miss[h] = False
                m = np.flatnonzero(miss)      # row gathers: boolean indexing of (N, 3) arrays is slow and keeps the GIL
                _scatter_add(L, np.take(sample, m), take_rows(thr, m) * self.background(take_rows(d, m), primary=depth == 0),
                             unique=depth == 0)
            if h.size == 0:
                break
            dsub = None
            if use_diffs:
                dsub = tuple(take_rows(x, h) for x in diffs)
            surf = surface_from_hits(self.ps.geo, hsub, take_rows(o, h), take_rows(d, h), dsub)
            if self.ps.has_normal_maps:
                apply_normal_maps(surf, materials)
            s_idx, thr_h = sample[h], take_rows(thr, h)
            if aovs is not None and depth == 0:
                aovs["depth"][s_idx] = hsub.t
                aovs["normal"][s_idx] = surf.ns
            mids = surf.material_id
            present = np.flatnonzero(np.bincount(mids, minlength=len(materials)))
            Lh = np.zeros((h.size, 3))
            # emission and ambient, per material type (only for materials that have them)
            use_ambient = np.any(ambient > 0)
            for k in present:
                mat = materials[k]
                want_albedo = aovs is not None and depth == 0
                if not (self.ps.emits[k] or want_albedo or (mat.has_diffuse and use_ambient)):
                    continue
                sel = np.flatnonzero(mids == k)
                ctx = surf.subset(sel)
                if self.ps.emits[k]:
                    Lh[sel] += mat.emission(ctx)
                if want_albedo:
                    aovs["albedo"][s_idx[sel]] = mat.albedo(ctx)
                if mat.has_diffuse and use_ambient:
                    Lh[sel] += mat.albedo(ctx) * ambient
            # direct light at hits whose material has a non-delta lobe
            diffuse_idx = np.flatnonzero(self.ps.has_diffuse[mids])
            if self.ps.face_gouraud is not None and diffuse_idx.size and lights:
                g = diffuse_idx[self.ps.face_gouraud[surf.face[diffuse_idx]]]
                if g.size:  # Gouraud faces: lighting at the vertices, interpolated (pyrt.integrators.gouraud)
                    Lh[g] += gouraud.direct_light(self, surf.subset(g), o[h[g]], rng)
                    diffuse_idx = np.setdiff1d(diffuse_idx, g, assume_unique=True)
            if diffuse_idx.size and lights:
                dm = mids[diffuse_idx]
                if dm.size > 1 and np.any(dm[1:] < dm[:-1]):
                    # ordered by material: BSDFBatch then dispatches every light's query by slicing
                    diffuse_idx = np.concatenate([diffuse_idx[dm == k] for k in np.flatnonzero(np.bincount(dm))])
                dsurf = surf.subset(diffuse_idx)
                bsdf = BSDFBatch(dsurf, materials)
                visible = self._visibility(dsurf)
                Ld = sum(light.estimate(dsurf, bsdf, visible, rng) for light in lights)
                put_rows(Lh, diffuse_idx, take_rows(Lh, diffuse_idx) + Ld)
            _scatter_add(L, s_idx, thr_h * Lh, unique=depth == 0)   # camera rays: one per sample
            if depth == self.max_depth:
                break
            # specular continuation
            new = self._spawn_specular(surf, thr_h, s_idx, dsub, None if media is None else stack[h])
            if new is None:
                break
            o, d, thr, sample, diffs, stack = new
        return L, aovs

    def _visibility(self, surf):
        def visible(idx, wi, dist, end=None):
            """Shadow rays from hits ``idx`` along ``wi`` to a light at ``dist`` (or at the point ``end``)."""
            sub = surf.subset(idx)
            origins, tmax = self.offset.shadow(sub, wi, dist, end)   # offsets.Strategy: origin, tmax, terminator
            return ~self._occluded(origins, wi, tmax)
        return visible

    def _spawn_specular(self, surf, thr_h, s_idx, dsub, stack_h=None):
        mids = surf.material_id
        spec_idx = np.flatnonzero(self.ps.has_delta[mids])
        if spec_idx.size == 0:
            return None
        media = self.ps.media if stack_h is not None else None
        eta_h = None if media is None else media.eta_for_hits(stack_h, mids, surf.front)
        parts = []
        for k in np.unique(mids[spec_idx]):
            sel = spec_idx[mids[spec_idx] == k]
            ctx = surf.subset(sel)
            wo_l = ctx.to_local(ctx.wo)
            kw = {"eta": eta_h[sel]} if media is not None and media.participates[k] else {}
            mat = self.scene.materials[k]
            for lobe in mat.delta_lobes(wo_l, ctx, **kw):
                t_new = thr_h[sel] * lobe.weight
                w_all = ctx.to_world(lobe.wi)
                alive = max_component(t_new) > self.throughput_cutoff
                if not mat.is_dielectric:
                    # A mirror reflection about an interpolated shading normal can point below the geometric
                    # surface. Such a ray is dropped (radiance 0): traced, it would enter the closed mirror
                    # object and stay trapped there until max_depth (the same black), or leak through an open
                    # one. Dielectrics keep theirs: inside glass the ray goes on and refracts out.
                    alive &= dot(w_all, ctx.ng) > 0
                keep = np.flatnonzero(alive)
                if keep.size == 0:
                    continue
                c = ctx.subset(keep)
                w = normalize_rows(take_rows(w_all, keep))
                origins = self.offset(c, w)
                new_d = None
                if dsub is not None:
                    gsel = sel[keep]
                    rx_d, ry_d = dsub[1][gsel], dsub[3][gsel]
                    if lobe.kind == "refract":
                        new_d = refract_differentials(c, rx_d, ry_d, w, lobe.eta[keep])
                    else:
                        new_d = reflect_differentials(c, rx_d, ry_d, w)
                parts.append((origins, w, t_new[keep], s_idx[sel[keep]], new_d, sel[keep], lobe.kind == "refract"))
        if not parts:
            return None
        o = np.concatenate([p[0] for p in parts])
        d = np.concatenate([p[1] for p in parts])
        thr = np.concatenate([p[2] for p in parts])
        sample = np.concatenate([p[3] for p in parts])
        diffs = None
        if dsub is not None:
            diffs = tuple(np.concatenate([p[4][i] for p in parts]) for i in range(4))
        stack = None
        if media is not None:  # the spawned rays' interface stacks (refraction crosses the interface)
            src = np.concatenate([p[5] for p in parts])
            refr = np.concatenate([np.full(p[5].size, p[6]) for p in parts])
            stack = media.spawn_stacks(stack_h, mids, surf.front, src, refr)
        return o, d, thr, sample, diffs, stack


def normalize_rows(w):
    n = np.linalg.norm(w, axis=1, keepdims=True)
    return np.divide(w, n, out=np.zeros_like(w), where=n > 0)


def _subset_hits(hits, idx):
    from pyrt.geometry.accel import Hits
    return Hits(hit=hits.hit[idx], t=hits.t[idx], mesh_id=hits.mesh_id[idx], prim_id=hits.prim_id[idx],
                u=hits.u[idx], v=hits.v[idx], ng=take_rows(hits.ng, idx))


@dataclass
class RenderResult:
    """Output of :func:`render_full`: linear radiance image, optional AOVs, statistics."""

    image: np.ndarray
    aovs: dict | None
    stats: RenderStats


def render_full(scene, *, spp=None, seed=0, max_depth=8, throughput_cutoff=1e-4, offset=None, aovs=False,
                progress=None, chunk_samples=1 << 15, threads=None, record_rays=False, prepared=None):
    """Render ``scene`` and return a :class:`RenderResult` (see :func:`render` for parameters).

    Chunks of pixels are shaded on a pool of ``threads`` workers (NumPy releases the GIL in its array
    loops, Embree in its traversal). Every chunk has its own random stream
    ``default_rng([seed, chunk_index])`` and writes a disjoint slice of the film, so the image does not
    depend on the number of threads or the order in which chunks finish.
    """
    t_start = time.perf_counter()
    cam = scene.camera
    if spp is not None:
        if int(spp) != spp or spp < 1:
            raise ValueError(f"spp must be a positive integer, got {spp!r}")
        from copy import copy
        cam = copy(cam)
        cam.spp = int(spp)
    if int(chunk_samples) != chunk_samples or chunk_samples < 1:
        raise ValueError(f"chunk_samples must be a positive integer, got {chunk_samples!r}")
    own = prepared is None
    ps = prepared if prepared is not None else PreparedScene(scene, threads=threads)
    W, H, S = cam.width, cam.height, cam.spp
    n_pix = W * H
    px_per_chunk = max(1, int(chunk_samples) // S)
    image = np.zeros((n_pix, 3))
    aov_img = None
    if aovs:
        aov_img = {"depth": np.zeros(n_pix), "normal": np.zeros((n_pix, 3)), "albedo": np.zeros((n_pix, 3))}
    starts = list(range(0, n_pix, px_per_chunk))

    def run_chunk(ci):
        lo = starts[ci]
        hi = min(lo + px_per_chunk, n_pix)
        integ = Integrator(ps, max_depth=max_depth, throughput_cutoff=throughput_cutoff, offset=offset,
                           record_rays=record_rays)
        rng = np.random.default_rng([seed, ci])
        o, d, pix, diffs = cam.generate_rays(lo, hi, rng, differentials=ps.needs_differentials)
        L, a = integ.render_samples(o, d, diffs, want_aovs=aovs, rng=rng)
        if not np.isfinite(L).all():          # one flat pass; per-sample only when something is wrong
            bad = ~np.all(np.isfinite(L), axis=1)
            integ.stats.nonfinite_samples += int(bad.sum())
            L[bad] = 0.0
        image[lo:hi] = L if S == 1 else L.reshape(hi - lo, S, 3).mean(axis=1)
        if aovs:
            dep = a["depth"].reshape(hi - lo, S)
            hitm = np.isfinite(dep)
            cnt = hitm.sum(axis=1)
            aov_img["depth"][lo:hi] = np.where(cnt > 0, np.where(hitm, dep, 0).sum(1) / np.maximum(cnt, 1), np.inf)
            aov_img["normal"][lo:hi] = a["normal"].reshape(hi - lo, S, 3).mean(axis=1)
            aov_img["albedo"][lo:hi] = a["albedo"].reshape(hi - lo, S, 3).mean(axis=1)
        return integ.stats

    from tqdm.auto import tqdm
    stats = RenderStats()
    workers = max(1, min(ps.accel.threads if threads is None else int(threads), len(starts)))
    bar = tqdm(total=len(starts), desc="render", unit="chunk", leave=False,
               disable=(not progress) if progress is not None else None)
    try:
        if workers == 1:
            results = []
            for ci in range(len(starts)):
                results.append(run_chunk(ci))
                bar.update()
        else:
            from concurrent.futures import ThreadPoolExecutor
            with ThreadPoolExecutor(max_workers=workers) as pool:
                futs = [pool.submit(run_chunk, ci) for ci in range(len(starts))]
                results = []
                for f in futs:
                    results.append(f.result())
                    bar.update()
    finally:
        bar.close()
        if own:
            ps.close()
    for st in results:  # merge in chunk order (deterministic)
        for k in ("primary_rays", "secondary_rays", "shadow_rays", "time_intersect", "time_occluded",
                  "nonfinite_samples"):
            setattr(stats, k, getattr(stats, k) + getattr(st, k))
        stats.recorded.extend(st.recorded)
    if stats.nonfinite_samples:
        warnings.warn(f"render: {stats.nonfinite_samples} samples had non-finite radiance and were "
                      "set to 0 (this is a bug; please report the scene)", RuntimeWarning, stacklevel=2)
    stats.time_total = time.perf_counter() - t_start
    img = to_float32(image.reshape(H, W, 3))
    if aov_img is not None:
        aov_img = {"depth": aov_img["depth"].reshape(H, W).astype(np.float32),
                   "normal": aov_img["normal"].reshape(H, W, 3).astype(np.float32),
                   "albedo": aov_img["albedo"].reshape(H, W, 3).astype(np.float32)}
    return RenderResult(image=img, aovs=aov_img, stats=stats)


def render(scene, **kwargs):
    """Render ``scene`` to linear radiance.

    Parameters
    ----------
    scene : pyrt.Scene
    spp : int, optional
        Samples per pixel (default: the camera's).
    seed : int
        Random seed; the same seed gives a bit-identical image.
    max_depth : int
        Maximum specular recursion depth (default 8).
    throughput_cutoff : float
        Drop specular rays whose throughput falls below this (default 1e-4).
    offset : str or callable
        Ray-offset strategy (:mod:`pyrt.geometry.offsets`): a name, a Strategy or a callable; default "robust"
        (local error bound + robust shadow tmax + shadow-terminator lift).
    progress : bool, optional
        Show a progress bar (default: only on a terminal).
    chunk_samples : int
        Camera samples per chunk (bounds memory; default 32768: measured fastest on the benchmark scene).
    threads : int, optional
        Worker threads for chunks and for Embree batches (default: all cores).

    Returns
    -------
    (H, W, 3) float32 ndarray
        Linear scene radiance (W m^-2 sr^-1 per RGB channel).
    """
    return render_full(scene, **kwargs).image


del math
