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

Steps 2, 4 and 5 go through hooks (``_sampled_hits``, ``_direct_light``, ``_spawn``, ``_escape_weight``,
``_emission_weight``) that are plain Whitted here; :class:`pyrt.integrators.glossy.GlossyIntegrator` overrides
them to add BSDF-sampled rays at glossy hits and their MIS weights, in the same loop.

This module knows nothing about Embree; it asks :class:`pyrt.geometry.accel.Accel` for hits and occlusion.
"""
from __future__ import annotations

import copy
import time

import numpy as np

from pyrt.core import checks
from pyrt.core.errors import RenderError
from pyrt.core.rays import RayBatch
from pyrt.core.sampler import PaddedStream, stream_rows
from pyrt.geometry import offsets
from pyrt.geometry.accel import T_INFINITE, Hits
from pyrt.geometry.differentials import refract_differentials, reflect_differentials
from pyrt.geometry.surface import surface_from_hits
from pyrt.integrators import coverage
from pyrt.integrators import direct
from pyrt.integrators import gouraud
from pyrt.integrators import light_choice
from pyrt.integrators import roulette
from pyrt.integrators.roulette import choose_one_lobe
from pyrt.integrators import shadows
from pyrt.integrators.prepared import RenderStats
from pyrt.materials.dispatch import BSDFBatch
from pyrt.textures import apply_normal_maps
from pyrt.shaders.vec import dot, max_component, put_rows, take_rows


#: what ``sampler=`` may be (:func:`pyrt.render_full`)
SAMPLERS = ("padded", "independent")
#: the bounce from which a dielectric hit follows one of its reflection and refraction instead of both (the
#: ``split_depth`` default of every render; :class:`Integrator` documents the measurement behind it)
DEFAULT_SPLIT_DEPTH = 3


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
        Specular rays whose max-channel throughput falls below this are dropped, or with ``roulette`` continue by
        Russian roulette (:mod:`pyrt.integrators.roulette`).
    roulette : bool
        Russian roulette below ``throughput_cutoff`` instead of dropping (unbiased; default False).
    offset : str or callable
        Ray-origin offset strategy (see :mod:`pyrt.geometry.offsets`).
    record_rays : bool
        Keep every traced ray (float32 origins, dirs, tmax, kind) in ``stats.recorded`` for benchmarks.
    transparent_shadows : bool
        Shadow rays pass through dielectrics, attenuated by Fresnel transmittance, tint and absorption
        (:mod:`pyrt.integrators.shadows`, an approximation; default off: strict Whitted). Only in scenes
        that have a dielectric; elsewhere the switch changes nothing.
    split_depth : int or None
        Bounce from which a hit on a dielectric with several delta lobes (reflection and refraction) continues
        along *one* of them instead of all (:func:`choose_one_lobe`: chosen with probability ``p`` in proportion
        to its mean RGB weight, weighted ``1 / p``; unbiased, noisier). Default :data:`DEFAULT_SPLIT_DEPTH` (3):
        Whitted's tree of rays for the camera hits and two bounces below them, one branch deeper, where a path has
        already crossed or bounced off three surfaces and contributes little: on the mirror/glass and default
        scenes of ``tools/bench_mitsuba.py`` (160 x 120, 16 and 64 spp, 3 seeds, against a 512-spp reference) the
        relMSE stayed within 1 % of the full tree's at 0.62-0.78 of its CPU time (relMSE x CPU 0.63-0.82; split
        depth 2: 0.64-0.85 with 15-28 % more relMSE; 4: 0.70-0.84). None: every lobe at every bounce (the full tree,
        deterministic: what tests of exact series use); 0: one branch from the camera hits on. The previewer passes
        its own (None).
    light_select_depth : int or None
        Bounce from which the delta lights (point, spot, directional) light a hit by one of them, chosen by its
        irradiance there (:mod:`pyrt.integrators.light_choice`: one shadow ray instead of one per light;
        unbiased, noisier), at camera hits and hits of BSDF-sampled rays (not at hits reached by a delta ray:
        what mirrors and glass show keeps all lights). None (default): every light at every hit; the previewer
        uses 1 (the hits of glossy rays).
    batch_rays : int or None
        Shade a bounce in slices of at most this many rays (:meth:`render_samples`); None: all at once.
    sampler : {"padded", "independent"}
        Where the camera rays carry :attr:`pyrt.core.rays.RayBatch.strata` (the chunk functions set them for
        ``"padded"``), their hits' light and BSDF samples come from a :class:`pyrt.core.sampler.PaddedStream`:
        stratified over each pixel's samples in every dimension pair. Deeper bounces draw from the chunk's
        generator either way.
    """

    #: the largest contribution the direct light at a hit of a BSDF-sampled ray adds to its sample
    #: (:func:`clamp_sampled`; set by :class:`pyrt.integrators.glossy.GlossyIntegrator`, None: no clamp)
    glossy_clamp = None

    def __init__(self, prepared, *, max_depth=8, throughput_cutoff=1e-4, roulette=False, offset=None,
                 record_rays=False, transparent_shadows=False, split_depth=DEFAULT_SPLIT_DEPTH,
                 light_select_depth=None, batch_rays=None, sampler="padded"):
        self.max_depth = checks.integer("render", "max_depth", max_depth, RenderError, lo=0)
        self.throughput_cutoff = checks.finite_number("render", "throughput_cutoff", throughput_cutoff, RenderError,
                                                      lo=0.0)
        if not isinstance(roulette, (bool, np.bool_)):
            raise RenderError(f"render: roulette must be True or False, got {roulette!r}")
        self.roulette = bool(roulette)
        self.ps = prepared
        self.scene = prepared.scene
        self.offset = offsets.get_strategy(offset)
        self.record_rays = record_rays
        if not isinstance(transparent_shadows, (bool, np.bool_)):
            raise RenderError(f"render: transparent_shadows must be True or False, got {transparent_shadows!r}")
        #: closest-hit shadow loops only where they can change something (the scene has a dielectric)
        self.transparent_shadows = bool(transparent_shadows) and bool(np.any(prepared.dielectric))
        self.split_depth = None if split_depth is None else checks.integer("render", "split_depth", split_depth,
                                                                            RenderError, lo=0)
        self.light_select_depth = None if light_select_depth is None else checks.integer(
            "render", "light_select_depth", light_select_depth, RenderError, lo=0)
        #: the lights light_select_depth chooses between (the others are estimated as before)
        self.selectable_lights = [lt for lt in self.scene.lights if light_choice.selectable(lt)]
        for lt in self.scene.lights:   # an emissive-mesh light samples (and MIS-weights) its own scene's triangles
            if lt.scene_emitter and not lt.built_for(self.scene.meshes):
                raise RenderError(f"render: {lt.label} was built for other meshes than this scene's")
        #: shade a bounce in slices of at most this many rays (:meth:`render_samples`); None: all at once
        self.batch_rays = None if batch_rays is None else checks.integer("render", "batch_rays", batch_rays,
                                                                          RenderError, lo=1)
        if sampler not in SAMPLERS:
            raise RenderError(f"render: sampler must be one of {SAMPLERS}, got {sampler!r}")
        #: "padded": camera hits draw light and BSDF samples padded over their pixels' samples (RayBatch.strata)
        self.sampler = sampler
        self.stats = RenderStats()

    @property
    def pads_camera_hits(self):
        """True when the camera rays should carry :attr:`pyrt.core.rays.RayBatch.strata`: ``sampler="padded"`` and
        the camera hits draw light or BSDF samples (a light that is not a delta light; the glossy integrator's
        rays). Scenes lit by delta lights alone draw none there: no strata to build."""
        return self.sampler == "padded" and any(not lt.delta for lt in self.scene.lights)

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

    def _shadow_query(self, kind, query, o, d, tmax):
        """``query(o, d, tmax)`` counted and timed as shadow rays, recorded as ``kind`` if asked."""
        t0 = time.perf_counter()
        out = query(o, d, tmax)
        self.stats.time_occluded += time.perf_counter() - t0
        self.stats.shadow_rays += o.shape[0]
        if self.record_rays:
            self.stats.recorded.append((kind, o.astype(np.float32), d.astype(np.float32),
                                        np.minimum(tmax, T_INFINITE).astype(np.float32)))
        return out

    def _occluded(self, o, d, tmax):
        """Embree's occlusion query for shadow rays: True where blocked."""
        return self._shadow_query("occluded", self.ps.accel.occluded, o, d, tmax)

    def _shadow_hits(self, o, d, tmax):
        """Closest hits of shadow rays below ``tmax`` (transparent shadows), counted as shadow rays."""
        return self._shadow_query("intersect", self.ps.accel.intersect, o, d, tmax)

    def _retrace(self, o, d):
        """Closest hits (all rays) of rays continued past a skipped or blended surface, counted as secondary."""
        return self._intersect(o, d, "secondary")

    def _retrace_hits(self, o, d):
        """:meth:`_retrace` in the hits-only form ``(idx, hits)`` of :meth:`Accel.intersect_hits`."""
        return self._intersect(o, d, "secondary", hits_only=True)

    def _retrace_covered(self, o, d):
        """:meth:`_retrace` with cut-outs and culled faces skipped (no blend split; nested media's continuations)."""
        hits = self._retrace(o, d)
        if self.ps.coverage is None:
            return hits
        return self.ps.coverage.resolve(self.ps.geo, hits, o, d, None, self._retrace, self.offset, split=False)[2]

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
    def render_samples(self, rays, want_aovs=False, rng=None):
        """Radiance (N, 3) float64 for the camera rays of the :class:`pyrt.core.rays.RayBatch` ``rays`` (their
        ``sample`` indices are 0..N-1), and the first hit's AOVs if asked (``depth``, ``normal``, ``albedo``).

        Bounce by bounce (:meth:`_bounce`); with :attr:`batch_rays` set, a bounce of more rays is shaded in slices
        of at most that many and the rays the slices spawn make the next bounce's one batch: the working set is
        a slice's, and a small deep bounce is still one batch (one texture lookup, BSDF and shadow query per
        material and light for the whole chunk)."""
        n = rays.size
        L = np.zeros((n, 3))
        aovs = None
        if want_aovs:
            aovs = {"depth": np.full(n, np.inf), "normal": np.zeros((n, 3)), "albedo": np.zeros((n, 3))}
        rng = rng if rng is not None else np.random.default_rng(0)
        use_diffs = rays.differentials is not None and self.ps.needs_differentials
        batch = rays
        if self.ps.media is not None and rays.stack is None:
            batch = copy.copy(rays)
            batch.stack = self.ps.media.empty(n)
        step = self.batch_rays
        for depth in range(self.max_depth + 1):
            if batch is None or batch.size == 0:
                break
            if step is None or batch.size <= step:
                batch = self._bounce(depth, batch, L, aovs, rng, use_diffs)
            else:
                parts = [self._bounce(depth, batch.rows(lo, min(lo + step, batch.size)), L, aovs, rng, use_diffs)
                         for lo in range(0, batch.size, step)]
                parts = [b for b in parts if b is not None and b.size]
                batch = RayBatch.concatenate(parts) if parts else None
        return L, aovs

    def _bounce(self, depth, batch, L, aovs, rng, use_diffs):
        """Shade the rays ``batch`` of bounce ``depth``: their radiance added into ``L`` at their ``sample`` rows
        (camera hits' AOVs into ``aovs``); returns the rays they spawn (a :class:`RayBatch` of bounce ``depth +
        1``), or None."""
        o, d, thr, sample, diffs = batch.origins, batch.directions, batch.throughput, batch.sample, batch.differentials
        stack = batch.stack
        strata = batch.strata      # camera rays: padded light / BSDF samples at their hits (None: independent)
        bpdf = batch.bsdf_pdf      # MIS state of BSDF-sampled rays (None: none in the batch)
        materials = self.scene.materials
        lights = self.scene.lights
        ambient = self.scene.ambient
        media = self.ps.media
        cover = self.ps.coverage
        kind = "primary" if depth == 0 else "secondary"
        n_rays = o.shape[0]   # rays of this bounce; blend surfaces append records after them (coverage)
        if media is None and cover is not None and not cover.shadows:   # culling only: hits-only queries
            h, hsub = self._intersect(o, d, kind, hits_only=True)
            h, hsub, dropped = cover.cull_hits(self.ps.geo, h, hsub, o, d, self._retrace_hits, self.offset)
            if dropped.size:      # more than coverage.MAX_LAYERS culled faces on the way: radiance 0
                thr = thr.copy()
                thr[dropped] = 0.0
        elif media is not None or cover is not None:
            hits = self._intersect(o, d, kind)
            if cover is not None:  # alpha cut-outs skipped, blend surfaces split, back faces culled
                parent, w, hits = cover.resolve(self.ps.geo, hits, o, d, diffs if use_diffs else None,
                                                self._retrace, self.offset, thr_max=max_component(thr),
                                                cutoff=self.throughput_cutoff)
                if parent.size > n_rays:   # blend records: the rays they continue, weighted
                    o, d, sample = take_rows(o, parent), take_rows(d, parent), np.take(sample, parent)
                    thr = take_rows(thr, parent)
                    diffs = None if diffs is None else tuple(take_rows(x, parent) for x in diffs)
                    stack = None if stack is None else stack[parent]
                    bpdf = None if bpdf is None else np.take(bpdf, parent)
                    strata = None if strata is None else tuple(None if x is None else np.take(x, parent)
                                                               for x in strata)
                if np.any(w != 1.0):
                    thr = thr * w[:, None]
            if media is not None:  # nested dielectrics: continue through false hits; Beer-Lambert absorption
                hits, seg_t, stack = media.skip_false_hits(
                    self.ps.geo, hits, o, d, stack, self._retrace_covered,
                    lambda hs, o2, d2: self.offset(surface_from_hits(self.ps.geo, hs, o2, d2), d2))
                thr = thr * media.attenuation(stack, seg_t)
            h = np.flatnonzero(hits.hit)
            hsub = _subset_hits(hits, h)
        else:
            h, hsub = self._intersect(o, d, kind, hits_only=True)
            if depth == 0 and self.ps.face_gouraud is None:
                h, hsub = self._by_material(h, hsub)
        one_per_sample = depth == 0 and o.shape[0] == n_rays   # camera rays, no blend split: unique samples
        if h.size < o.shape[0]:
            miss = np.ones(o.shape[0], dtype=bool)
            miss[h] = False
            m = np.flatnonzero(miss)      # row gathers: boolean indexing of (N, 3) arrays is slow and keeps the GIL
            Lm = self.background(take_rows(d, m), primary=depth == 0)
            if bpdf is not None:   # escaped BSDF-sampled rays: MIS against the environment's light sampling
                Lm = Lm * self._escape_weight(take_rows(d, m), np.take(bpdf, m))[:, None]
            _scatter_add(L, np.take(sample, m), take_rows(thr, m) * Lm, unique=one_per_sample)
        if h.size == 0:
            return None
        dsub = None
        if use_diffs:
            dsub = tuple(take_rows(x, h) for x in diffs)
        surf = surface_from_hits(self.ps.geo, hsub, take_rows(o, h), take_rows(d, h), dsub)
        if self.ps.has_normal_maps:
            apply_normal_maps(surf, materials)
        s_idx, thr_h = sample[h], take_rows(thr, h)
        # camera hits draw their light and BSDF samples padded over their pixels' samples (pyrt.core.sampler)
        rng_h = rng if strata is None else PaddedStream(rng, *(None if x is None else np.take(x, h) for x in strata))
        aov_rows = None
        if aovs is not None and depth == 0:   # the nearest surface a camera ray keeps (not blend records)
            aov_rows = np.flatnonzero(h < n_rays)
            aovs["depth"][s_idx[aov_rows]] = hsub.t[aov_rows]
            aovs["normal"][s_idx[aov_rows]] = surf.ns[aov_rows]
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
                Le = mat.emission(ctx)
                if bpdf is not None:   # emitters reached by BSDF-sampled rays: MIS against light sampling
                    Le = Le * self._emission_weight(k, take_rows(o, h[sel]), take_rows(d, h[sel]),
                                                    np.take(bpdf, h[sel]), ctx)[:, None]
                Lh[sel] += Le
            if want_albedo:
                first = h[sel] < n_rays
                aovs["albedo"][s_idx[sel[first]]] = mat.albedo(ctx)[first]
            if mat.has_diffuse and use_ambient:
                Lh[sel] += mat.albedo(ctx) * ambient
        # direct light at hits whose material has a non-delta lobe
        diffuse_idx = np.flatnonzero(self.ps.has_diffuse[mids])
        if self.ps.face_gouraud is not None and diffuse_idx.size and lights:
            g = diffuse_idx[self.ps.face_gouraud[surf.face[diffuse_idx]]]
            if g.size:  # Gouraud faces: lighting at the vertices, interpolated (pyrt.integrators.gouraud)
                Lh[g] += gouraud.direct_light(self.ps, lights, self.visibility, surf.subset(g), o[h[g]], rng)
                diffuse_idx = np.setdiff1d(diffuse_idx, g, assume_unique=True)
        sampled = self._sampled_hits(surf, diffuse_idx, depth)   # hits that trace their non-delta lobe
        if diffuse_idx.size and lights:
            dm = mids[diffuse_idx]
            rows = diffuse_idx
            if dm.size > 1 and np.any(dm[1:] < dm[:-1]):
                # ordered by material: BSDFBatch then dispatches every light's query by slicing
                order = np.concatenate([np.flatnonzero(dm == k) for k in np.flatnonzero(np.bincount(dm))])
                diffuse_idx = rows = diffuse_idx[order]
                sampled = None if sampled is None else sampled[order]
            elif diffuse_idx[-1] - diffuse_idx[0] + 1 == diffuse_idx.size:
                # increasing (flatnonzero) and as many as the span: one run of rows (camera hits ordered by
                # material, the diffuse materials side by side): views of the batch's fields, no gathers
                rows = slice(int(diffuse_idx[0]), int(diffuse_idx[-1]) + 1)
            dsurf = surf.subset(rows)
            bsdf = BSDFBatch(dsurf, materials)
            visible = self.visibility(dsurf)
            choose = None
            if self._selects_lights(depth):   # camera hits, or hits of BSDF-sampled rays: one light each
                choose = (np.ones(diffuse_idx.size, dtype=bool) if depth == 0 else
                          np.take(bpdf, h[diffuse_idx]) > 0 if bpdf is not None else None)
                choose = choose if choose is not None and choose.any() else None
            Ld = self._direct_light(dsurf, bsdf, visible, stream_rows(rng_h, diffuse_idx), sampled, depth, choose)
            if bpdf is not None and self.glossy_clamp is not None:   # hits of glossy rays (GlossyIntegrator)
                Ld = clamp_sampled(Ld, take_rows(thr_h, diffuse_idx), np.take(bpdf, h[diffuse_idx]) > 0,
                                   self.glossy_clamp)
            put_rows(Lh, diffuse_idx, take_rows(Lh, diffuse_idx) + Ld)
        _scatter_add(L, s_idx, thr_h * Lh, unique=one_per_sample)   # camera rays: one per sample
        if depth == self.max_depth:
            return None
        # specular continuation
        new = self._spawn(surf, thr_h, s_idx, dsub, None if media is None else stack[h], diffuse_idx, sampled,
                          depth, rng_h)
        if new is not None:
            new.depth = depth + 1
        return new

    def visibility(self, surf):
        """``visible(idx, wi, dist, end=None)`` for the hits of ``surf``: shadow rays through Embree's occlusion
        query from the offset origins (:mod:`pyrt.geometry.offsets`) to the light, a bool array True where
        unblocked; with :attr:`transparent_shadows` (and a dielectric in the scene) a transmittance (k, 3)
        through the dielectrics on the way (:func:`pyrt.integrators.shadows.transmittance`) instead; in a scene with
        alpha-masked or blended materials (:mod:`pyrt.integrators.coverage`) always a transmittance: the rays the
        occlusion query finds blocked are re-traced through those surfaces (and through dielectrics with
        :attr:`transparent_shadows`)."""
        cover = self.ps.coverage
        if (cover is not None and cover.shadows) or self.transparent_shadows:
            covers = cover if cover is not None and cover.shadows else None
            layers = coverage.MAX_LAYERS if covers is not None else shadows.MAX_INTERFACES

            def transmitted(idx, wi, dist, end=None):
                """Transmittance (k, 3) of the shadow rays from hits ``idx`` along ``wi`` to the light through
                see-through surfaces: the cheap any-hit query first, the closest-hit walk
                (:func:`pyrt.integrators.shadows.transmittance`) only for the rays it finds blocked (the others
                would find no hit on its first step: the same values, exactly)."""
                origins, tmax = self.offset.shadow(surf.subset(idx), wi, dist, end)
                T = np.ones((idx.size, 3))
                b = np.flatnonzero(self._occluded(origins, wi, tmax))
                if b.size:
                    T[b] = shadows.transmittance(self.ps, self.offset, take_rows(origins, b), take_rows(wi, b),
                                                 np.take(tmax, b), self._shadow_hits, layers,
                                                 coverage=covers, dielectrics=self.transparent_shadows)
                return T
            return transmitted

        def visible(idx, wi, dist, end=None):
            """Shadow rays from hits ``idx`` along ``wi`` to a light at ``dist`` (or at the point ``end``)."""
            sub = surf.subset(idx)
            origins, tmax = self.offset.shadow(sub, wi, dist, end)   # offsets.Strategy: origin, tmax, terminator
            return ~self._occluded(origins, wi, tmax)
        return visible

    def _by_material(self, h, hits):
        """The camera rays' hits ``h`` and their :class:`Hits` reordered by material id (stable: in ray order
        within a material), so that the surface batch's material groups are runs of rows and the direct-light
        and BSDF queries read views of its fields instead of gathering them.

        The estimators see the hits in the order they saw before (they ordered the hits with a non-delta
        lobe by material themselves, stably, and spawn delta rays per material in ray order), and camera
        rays have one hit per sample (results are put, not summed): images stay bit-identical. Only camera
        rays are reordered: at later depths several rays of one sample are summed in array order.
        """
        geo = self.ps.geo
        mat = geo.face_material[geo.face_offset[hits.mesh_id] + hits.prim_id]
        if mat.size < 2 or not np.any(mat[1:] < mat[:-1]):
            return h, hits
        order = np.concatenate([np.flatnonzero(mat == k) for k in np.flatnonzero(np.bincount(mat))])
        return h[order], _subset_hits(hits, order)

    # -- hooks of the recursion (the Whitted versions; pyrt.integrators.glossy overrides them) -----------
    def _sampled_hits(self, surf, idx, depth):
        """Which hits ``idx`` (indices into ``surf``) continue along BSDF-sampled rays: a bool mask over ``idx``,
        or None (Whitted: none; only delta lobes spawn rays)."""
        return None

    def _direct_light(self, dsurf, bsdf, visible, rng, sampled, depth, choose=None):
        """Direct light (N, 3) at the hits of ``dsurf`` (``sampled``: the mask of :meth:`_sampled_hits`); the hits
        of the mask ``choose`` (None: none) are lit by one chosen delta light each (:meth:`_selects_lights`)."""
        if choose is None:
            return direct.estimate(self.scene.lights, dsurf, bsdf, visible, rng)
        rest = [lt for lt in self.scene.lights if lt not in self.selectable_lights]
        L = direct.estimate(rest, dsurf, bsdf, visible, rng)
        return L + light_choice.one_light_estimate(self.selectable_lights, dsurf, bsdf, visible, rng, choose)

    def _selects_lights(self, depth):
        """True where bounce ``depth`` may light hits by one chosen delta light (:mod:`pyrt.integrators.light_choice`):
        from :attr:`light_select_depth` on, when there are at least two to choose from; then the camera rays' hits
        and those of BSDF-sampled rays (``bsdf_pdf > 0``) are, hits reached by a mirror or glass (delta) ray are not
        (what is seen through glass keeps every light's shadow ray)."""
        return (self.light_select_depth is not None and depth >= self.light_select_depth
                and len(self.selectable_lights) > 1)

    def _spawn(self, surf, thr_h, s_idx, dsub, stack_h, idx, sampled, depth, rng):
        """The next :class:`RayBatch` (Whitted: the delta lobes, :meth:`_spawn_specular`), or None."""
        return self._spawn_specular(surf, thr_h, s_idx, dsub, stack_h, depth, rng)

    def _escape_weight(self, d, bsdf_pdf):
        """MIS weight (N,) of the environment seen by escaped BSDF-sampled rays (Whitted traces none: 1)."""
        return np.ones(d.shape[0])

    def _emission_weight(self, k, o, d, bsdf_pdf, ctx=None):
        """MIS weight (N,) of material ``k``'s emission reached by BSDF-sampled rays from ``o`` along ``d`` at the
        hits ``ctx`` (their mesh, triangle and distance ``t``; Whitted: 1)."""
        return np.ones(d.shape[0])

    def _spawn_specular(self, surf, thr_h, s_idx, dsub, stack_h=None, depth=0, rng=None):
        """The next :class:`RayBatch`: every delta lobe of the hits' materials (mirror, glass reflection and
        refraction) with multiplied throughput, or None when no ray survives. From bounce :attr:`split_depth`
        on, dielectrics continue along one lobe per hit (:func:`choose_one_lobe`, random numbers from ``rng``)."""
        select = self.split_depth is not None and depth >= self.split_depth
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
            thr_k = take_rows(thr_h, sel)      # row gathers, not fancy indexing of (N, 3) rows (3-4x slower)
            lobes = mat.delta_lobes(wo_l, ctx, **kw)
            if select and mat.is_dielectric and len(lobes) > 1:
                lobes = choose_one_lobe(lobes, rng.random(sel.size))
            for lobe in lobes:
                w_all = ctx.to_world(lobe.wi)
                alive, t_new = roulette.survivors(thr_k * lobe.weight, self.throughput_cutoff, rng if self.roulette else None)
                if not mat.is_dielectric:
                    # A mirror reflection about an interpolated shading normal can point below the geometric
                    # surface. Such a ray is dropped (radiance 0): traced, it would enter the closed mirror
                    # object and stay trapped there until max_depth (the same black), or leak through an open
                    # one. Dielectrics keep theirs: inside glass the ray goes on and refracts out.
                    alive &= dot(w_all, ctx.ng) > 0
                keep = np.flatnonzero(alive)
                if keep.size == 0:
                    continue
                refract = lobe.kind == "refract"
                parts.append((sel[keep], normalize_rows(take_rows(w_all, keep)), t_new[keep], refract,
                              lobe.eta[keep] if refract else None))
        if not parts:
            return None
        # every material's rays at once: origins and differentials are per-row formulas (the same numbers as
        # material by material), in the order the parts were made (the next bounce's rays keep their order)
        src = np.concatenate([p[0] for p in parts])
        d = np.concatenate([p[1] for p in parts])
        thr = np.concatenate([p[2] for p in parts])
        refr = np.concatenate([np.full(p[0].size, p[3]) for p in parts])
        c = surf.subset(src)
        o = self.offset(c, d)
        diffs = None
        if dsub is not None:
            rx_d, ry_d = take_rows(dsub[1], src), take_rows(dsub[3], src)
            eta = np.concatenate([p[4] for p in parts if p[3]]) if refr.any() else None
            if eta is None:                       # reflections only (mirrors, glass past split_depth...)
                diffs = reflect_differentials(c, rx_d, ry_d, d)
            elif eta.size == src.size:            # refractions only
                diffs = refract_differentials(c, rx_d, ry_d, d, eta)
            else:
                diffs = tuple(np.empty_like(rx_d) for _ in range(4))
                for rows, fn in ((np.flatnonzero(~refr), reflect_differentials),
                                 (np.flatnonzero(refr), refract_differentials)):
                    args = (c.subset(rows), take_rows(rx_d, rows), take_rows(ry_d, rows), take_rows(d, rows))
                    part = fn(*args) if fn is reflect_differentials else fn(*args, eta)
                    for out, val in zip(diffs, part):
                        put_rows(out, rows, val)
            diffs = tuple(diffs)
        stack = None
        if media is not None:
            # The spawned rays' interface stacks: a ray that leaves below the geometric surface crosses the interface,
            # one that leaves above it does not, whichever lobe it came from. About an interpolated shading normal
            # a refraction can point above the triangle (it stays outside) and a reflection inside the glass below it
            # (it leaves): counted by the lobe, the stack said "inside" for a ray in the air, Beer-Lambert absorbed
            # it on its way and an escape to the environment came back 0 (a dark speckle on thick glass).
            crossed = dot(d, c.ng) < 0
            stack = media.spawn_stacks(stack_h, mids, surf.front, src, crossed)
        sample = np.take(s_idx, src)
        return RayBatch(o, d, sample=sample, throughput=thr, differentials=diffs, stack=stack)


def clamp_sampled(Ld, thr, sampled, limit):
    """``Ld`` (N, 3) with the rows ``sampled`` scaled down where their contribution ``thr * Ld`` exceeds ``limit`` in
    its largest channel (to exactly ``limit`` there, the colour kept): the glossy integrator's ``glossy_clamp``."""
    m = max_component(thr * Ld)
    over = np.flatnonzero(sampled & (m > limit))
    if over.size == 0:
        return Ld
    Ld = Ld.copy()
    put_rows(Ld, over, take_rows(Ld, over) * (limit / np.take(m, over))[:, None])
    return Ld


def normalize_rows(w):
    """``w / |w|`` per row (zero rows stay zero), column by column: the same values as dividing by
    ``np.linalg.norm(w, axis=1, keepdims=True)`` (its sum of squares runs in the same order) at a third
    of the cost of broadcasting over the 3-wide axis."""
    n = np.sqrt(dot(w, w))
    ok = n > 0
    out = np.zeros_like(w)
    for c in range(w.shape[1]):
        np.divide(w[:, c], n, out=out[:, c], where=ok)
    return out


def _subset_hits(hits, idx):
    return Hits(hit=hits.hit[idx], t=hits.t[idx], mesh_id=hits.mesh_id[idx], prim_id=hits.prim_id[idx],
                u=hits.u[idx], v=hits.v[idx], ng=take_rows(hits.ng, idx))
