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
import math
import time
import warnings

import numpy as np

from pyrt.geometry import offsets
from pyrt.geometry.accel import Accel, T_INFINITE
from pyrt.geometry.surface import refract_differentials, reflect_differentials, surface_from_hits
from pyrt.integrators import direct
from pyrt.integrators import gouraud
from pyrt.integrators.media import NestedMedia
from pyrt.materials.dispatch import BSDFBatch
from pyrt.textures.texture import apply_normal_maps
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
        self.face_gouraud = gouraud.face_mask(self.geo, scene.gouraud_meshes)
        self.needs_differentials = any(m.uses_textures for m in mats)
        #: materials whose emission() can be non-zero (the rest skip the emission pass)
        self.emits = np.array([m.emits for m in mats], dtype=bool)
        # materials with a tangent-space normal map (Material.normal_map, see pyrt.textures)
        self.has_normal_maps = any(m.normal_map is not None for m in mats)

    def close(self):
        self.accel.close()


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
            if primary and env.hide_background:
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
                    Lh[g] += gouraud.direct_light(self.ps, lights, self.visibility, surf.subset(g), o[h[g]], rng)
                    diffuse_idx = np.setdiff1d(diffuse_idx, g, assume_unique=True)
            if diffuse_idx.size and lights:
                dm = mids[diffuse_idx]
                if dm.size > 1 and np.any(dm[1:] < dm[:-1]):
                    # ordered by material: BSDFBatch then dispatches every light's query by slicing
                    diffuse_idx = np.concatenate([diffuse_idx[dm == k] for k in np.flatnonzero(np.bincount(dm))])
                dsurf = surf.subset(diffuse_idx)
                bsdf = BSDFBatch(dsurf, materials)
                visible = self.visibility(dsurf)
                Ld = direct.estimate(lights, dsurf, bsdf, visible, rng)
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

    def visibility(self, surf):
        """``visible(idx, wi, dist, end=None)`` for the hits of ``surf``: shadow rays through Embree's occlusion
        query from the offset origins (:mod:`pyrt.geometry.offsets`) to the light, True where unblocked."""
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
