"""Glossy reflection rays (distribution ray tracing, Cook, Porter & Carpenter 1984) on the Whitted recursion.

:class:`GlossyIntegrator` (``render_full(..., integrator="glossy")``) is the Whitted wavefront loop of
:class:`pyrt.integrators.whitted.Integrator` with its hooks overridden; it adds, at every hit whose material
declares a glossy lobe (:meth:`pyrt.materials.Material.glossy_alpha` ``<= glossy_threshold``), rays sampled
from the material's non-delta BSDF (``BSDFBatch.sample``): ``glossy_samples`` per hit on the first bounce,
one deeper, none from bounce ``glossy_depth`` on. Each carries ``throughput * weight / n`` and
``bsdf_pdf = n * pdf`` (:class:`pyrt.core.rays.RayBatch`). Above the threshold a lobe counts as diffuse:
direct light only, as in Whitted. Rough transmission (:meth:`pyrt.materials.Material.rough_transmission`: rough
glass, glTF transmission above its smooth limit) is the exception: its hits trace one sampled ray at every bounce
up to ``max_depth``, whatever the depth and threshold, as delta lobes do. A path through thick rough glass crosses
at least two surfaces per wall, and cut at ``glossy_depth`` it ended black: on ``tools/glass_scenes.py``'s thick
glass at roughness 0.15 the glass was 2.2-4.5x too dark (mean RGB 0.077, 0.101, 0.112 against 0.167, 0.368,
0.510), a dark speckle.

MIS (Veach 1997, power heuristic with the sample counts; pbrt-v4 ``PathIntegrator::SampleLd`` and the
emitted-radiance weight on the next hit). At a hit that traces glossy rays, a direction can reach a light by
two strategies: light sampling (``n_l = light.n_samples`` samples, density ``p_l = light.pdf_li``) and the
glossy rays (``n_b`` samples, density ``p_b``). Light samples are weighted by
``w_l = (n_l p_l)^2 / ((n_l p_l)^2 + (n_b p_b)^2)``, the emission or environment a glossy ray reaches by
``w_b = 1 - w_l`` (the same two numbers), so every direction is counted once:

- delta lights (point, spot, directional): light sampling only, weight 1;
- area lights whose visible emitter mesh is in the scene (``AreaLight.add_to(scene)``: the mesh named
  ``"<light name>_emitter"``): both strategies, MIS. An area light without a visible mesh is light-sampled
  only (weight 1); an emissive mesh that is no light is reached by glossy rays only (weight 1). The light's
  exact shape is sampled while rays hit its triangulated mesh: a disk or sphere light is counted with
  weight ``w_l`` instead of 1 on the sliver between the two (below 1% of the area at 64 segments);
- emissive meshes made a light by ``Scene.add_emissive_lights`` (:class:`pyrt.EmissiveMeshLight`, every triangle
  of an emitting material): both strategies, MIS, with the densities of the *point*: a light sample carries its
  own ``p_l = pmf / area * r^2 / |cos|`` (:attr:`LightSample.pdf`), and a glossy ray that hits one of the
  light's triangles gets ``w_b`` from :meth:`Light.pdf_hit` with the hit's mesh, triangle, distance ``t`` and
  cosine (no extra ray). Triangles the light does not sample (``pmf = 0``: no emission at its probe points)
  have ``p_l = 0``, so their emission keeps weight 1, as do delta (mirror, glass) rays and camera rays;
- the environment light: at glossy hits it is light-sampled with its map (``Environment.sample``, whatever
  its ``strategy``; its own BSDF half of ``"mis"`` is left to the glossy rays) and MIS-weighted; with
  ``strategy="bsdf"`` or ``"preview"`` it is not light-sampled there and escaped glossy rays count with
  weight 1, as they do when the environment is only a background (no :class:`EnvironmentLight`).
  Hits that trace no glossy ray keep the light's own strategy.
"""
from __future__ import annotations

import numpy as np

from pyrt.core import checks
from pyrt.core.errors import RenderError
from pyrt.core.rays import RayBatch
from pyrt.core.sampler import stratified_samples, stream_rows
from pyrt.geometry.differentials import reflect_differential_terms
from pyrt.integrators import direct
from pyrt.integrators import light_choice
from pyrt.integrators import roulette
from pyrt.integrators.whitted import Integrator, normalize_rows
from pyrt.materials.dispatch import BSDFBatch
from pyrt.shaders import sampling
from pyrt.shaders.vec import dot, put_rows, take_rows

#: environment strategies that light-sample at glossy hits (the others leave the environment to the rays)
ENV_LIGHT_SAMPLED = ("uniform", "cosine", "map", "mis")


def emitter_lights(scene):
    """``{material index: [area lights]}``: the area lights whose visible emitter mesh (:meth:`AreaLight.add_to`, the
    mesh named ``"<light name>_emitter"``) is in ``scene`` with an emitting material, by that material: the lights
    glossy rays reach, whose emission they weigh by MIS."""
    out = {}
    by_name = {}
    for lt in scene.lights:
        if lt.has_mesh and not lt.delta:
            by_name.setdefault(lt.emitter_mesh_name, []).append(lt)
    for mesh in scene.meshes:
        lts = by_name.get(mesh.name)
        if lts and scene.materials[mesh.material_id].emits:
            out.setdefault(mesh.material_id, [])
            out[mesh.material_id] += [lt for lt in lts if lt not in out[mesh.material_id]]
    return out


def mis_weights(n_light, pdf_light, n_bsdf, pdf_bsdf):
    """The two power-heuristic weights ``(w_light, w_bsdf)`` of one direction, which sum to one.

    ``pdf_light``, ``pdf_bsdf`` (N,) are the solid-angle densities of the direction under light sampling
    (``n_light`` samples) and BSDF sampling (``n_bsdf`` samples); where both are 0 both weights are 0.
    """
    return (sampling.power_heuristic(pdf_light, pdf_bsdf, 2.0, n_light, n_bsdf),
            sampling.power_heuristic(pdf_bsdf, pdf_light, 2.0, n_bsdf, n_light))


class GlossyIntegrator(Integrator):
    """Whitted plus BSDF-sampled rays at glossy hits, with MIS against light sampling (module docstring).

    Parameters
    ----------
    prepared : PreparedScene
    glossy_samples : int
        BSDF samples per glossy hit on the first bounce (deeper bounces: 1).
    glossy_depth : int
        Glossy rays are spawned at bounces ``0 .. glossy_depth - 1`` (and below ``max_depth``); rough transmission
        at every bounce below ``max_depth`` (the module docstring).
    glossy_threshold : float
        Lobes with ``glossy_alpha > glossy_threshold`` count as diffuse (direct light only).
    glossy_clamp : float or None
        The largest radiance (max channel, times the path's throughput) that the direct light at a hit of a glossy
        ray may add to its camera sample; larger ones are scaled down to it, the colour kept
        (:func:`pyrt.integrators.whitted.clamp_sampled`). Biased: it removes the rare, very bright samples of
        glossy -> sharp lobe -> light paths (a sharp highlight or a small emitter seen in a glossy reflection: the
        fireflies of a few-sample render) and darkens what they estimate. Hits reached by delta rays and the
        emission and environment that glossy rays reach are not clamped. None (default): unbiased.
    **kwargs
        Those of :class:`pyrt.integrators.whitted.Integrator`.
    """

    def __init__(self, prepared, *, glossy_samples=4, glossy_depth=2, glossy_threshold=0.4, glossy_clamp=None,
                 **kwargs):
        super().__init__(prepared, **kwargs)
        self.glossy_clamp = None if glossy_clamp is None else checks.finite_number(
            "render", "glossy_clamp", glossy_clamp, RenderError, lo=0.0)
        self.glossy_samples = checks.integer("render", "glossy_samples", glossy_samples, RenderError, lo=1)
        self.glossy_depth = checks.integer("render", "glossy_depth", glossy_depth, RenderError, lo=0)
        self.glossy_threshold = checks.finite_number("render", "glossy_threshold", glossy_threshold, RenderError,
                                                     lo=0.0)
        scene = self.scene
        # material index -> the area lights whose visible emitter mesh uses it (see AreaLight.add_to)
        self.emitter_lights = emitter_lights(scene)
        self.traced_lights = [lt for lts in self.emitter_lights.values() for lt in lts]
        # emissive-mesh lights (Scene.add_emissive_lights): the rays that hit their triangles reach them
        self.mesh_lights = [lt for lt in scene.lights if lt.scene_emitter]
        self.traced_lights += self.mesh_lights
        env_lights = [lt for lt in scene.lights if lt.environment is not None and lt.strategy in ENV_LIGHT_SAMPLED]
        self.env_light = env_lights[0] if env_lights else None

    def n_glossy(self, depth):
        """BSDF samples per glossy hit at bounce ``depth``."""
        return self.glossy_samples if depth == 0 else 1

    # -- hooks -------------------------------------------------------------------------------
    def _sampled_hits(self, surf, idx, depth):
        """Hits ``idx`` whose material is glossy enough (:meth:`Material.glossy_alpha`), before ``glossy_depth``;
        and at every bounce below ``max_depth`` the hits that transmit through a rough lobe
        (:meth:`Material.rough_transmission`: a path inside rough glass is not cut at ``glossy_depth``)."""
        if depth >= self.max_depth or idx.size == 0:
            return None
        glossy = depth < self.glossy_depth
        mask = np.zeros(idx.size, dtype=bool)
        mids = surf.material_id[idx]
        for k in np.flatnonzero(np.bincount(mids)):
            mat = self.scene.materials[k]
            if not glossy and not mat.transmits:
                continue
            sel = np.flatnonzero(mids == k)
            sub = surf.subset(idx[sel])
            if glossy:
                alpha = mat.glossy_alpha(sub)
                if alpha is not None:
                    mask[sel] = alpha <= self.glossy_threshold
            if mat.transmits:
                mask[sel] |= mat.rough_transmission(sub)
        if self.ps.face_gouraud is not None:       # lighting at the vertices: no rays from there
            mask &= ~self.ps.face_gouraud[surf.face[idx]]
        return mask if mask.any() else None

    def _direct_light(self, dsurf, bsdf, visible, rng, sampled, depth, choose=None):
        """Direct light with the light samples at glossy hits MIS-weighted against the glossy rays."""
        if sampled is None:
            return super()._direct_light(dsurf, bsdf, visible, rng, sampled, depth, choose)
        nb = self.n_glossy(depth)
        L = np.zeros((dsurf.n_hits, 3))
        gi, pi = np.flatnonzero(sampled), np.flatnonzero(~sampled)
        select = choose is not None
        if select:         # one delta light per chosen hit (their samples have MIS weight 1 here too)
            L += light_choice.one_light_estimate(self.selectable_lights, dsurf, bsdf, visible, rng, choose)
        for light in self.scene.lights:
            if select and light in self.selectable_lights:
                continue
            if light.environment is None:
                if light.delta or light not in self.traced_lights:
                    L += direct.light_sampling_estimate(light, dsurf, bsdf, visible, rng)
                    continue

                def w_light(idx, wi, pdf=None, light=light):
                    p_l = light.pdf_li(take_rows(dsurf.p, idx), wi) if pdf is None else pdf
                    w = mis_weights(light.n_samples, p_l, nb, bsdf.pdf(idx, wi))[0]
                    return np.where(sampled[idx], w, 1.0)
                L += direct.light_sampling_estimate(light, dsurf, bsdf, visible, rng, weight=w_light)
                continue
            if pi.size:      # hits without glossy rays: the light's own strategy
                put_rows(L, pi, take_rows(L, pi) + self._on_subset(direct.estimate_light, light, dsurf, pi,
                                                                   visible, rng))
            if light is self.env_light:   # glossy hits: the map, MIS-weighted
                put_rows(L, gi, take_rows(L, gi) + self._on_subset(self._env_light_sampling, light, dsurf, gi,
                                                                   visible, rng, nb))
        return L

    def _on_subset(self, fn, light, dsurf, idx, visible, rng, *args):
        """``fn(light, sub, BSDFBatch(sub), visible on sub, rng, *args)`` for ``sub = dsurf.subset(idx)``."""
        sub = dsurf.subset(idx)

        def vis(i, wi, dist, end=None):
            """Shadow rays from the subset's hits ``i``."""
            return visible(idx[i], wi, dist, end)
        return fn(light, sub, BSDFBatch(sub, self.scene.materials), vis, rng, *args)

    @staticmethod
    def _env_light_sampling(light, surf, bsdf, visible, rng, nb):
        """The environment by its map at glossy hits, light samples weighted by ``w_l`` against ``nb`` rays."""
        def w_light(idx, wi, pdf=None):
            return mis_weights(light.n_samples, light.pdf_li(None, wi), nb, bsdf.pdf(idx, wi))[0]
        return direct.light_sampling_estimate(light, surf, bsdf, visible, rng, weight=w_light)

    def _escape_weight(self, d, bsdf_pdf):
        """``w_b`` of the environment for escaped glossy rays (1 for delta-lobe rays and an unsampled map)."""
        if self.env_light is None:
            return np.ones(d.shape[0])
        lt = self.env_light
        w = mis_weights(lt.n_samples, lt.pdf_li(None, d), 1, bsdf_pdf)[1]
        return np.where(bsdf_pdf > 0, w, 1.0)

    def _emission_weight(self, k, o, d, bsdf_pdf, ctx=None):
        """``w_b`` of material ``k``'s emission for glossy rays from ``o`` along ``d`` hitting ``ctx`` (1 if it is no
        light): area lights by their ``pdf_li`` of the direction, emissive-mesh lights by their density at the
        hit point (:meth:`Light.pdf_hit`: the hit's triangle, distance and cosine; ``ctx`` is needed for them)."""
        lts = self.emitter_lights.get(int(k), [])
        mesh_lts = [lt for lt in self.mesh_lights if int(k) in lt.material_ids]
        if not lts and not mesh_lts:
            return np.ones(d.shape[0])
        p_l = sum(lt.n_samples * lt.pdf_li(o, d) for lt in lts)
        if mesh_lts:
            cos_l = dot(d, ctx.ng)
            p_l = p_l + sum(lt.n_samples * lt.pdf_hit(o, ctx.mesh_id, ctx.prim_id, ctx.t, cos_l) for lt in mesh_lts)
        w = mis_weights(1, p_l, 1, bsdf_pdf)[1]
        return np.where(bsdf_pdf > 0, w, 1.0)

    @property
    def pads_camera_hits(self):
        """As :attr:`Integrator.pads_camera_hits`, and the glossy rays sampled at camera hits draw too."""
        return self.sampler == "padded" and (self.glossy_depth > 0 or super().pads_camera_hits)

    def _spawn(self, surf, thr_h, s_idx, dsub, stack_h, idx, sampled, depth, rng):
        """The delta-lobe rays of :meth:`_spawn_specular` and the glossy rays of :meth:`_spawn_glossy`."""
        spec = self._spawn_specular(surf, thr_h, s_idx, dsub, stack_h, depth, rng)
        if sampled is None:
            return spec
        gl = self._spawn_glossy(surf, thr_h, s_idx, dsub, stack_h, idx[sampled], depth, rng)
        if gl is None or spec is None:
            return gl if spec is None else spec
        diffs = None
        if gl.differentials is not None:
            diffs = tuple(np.concatenate([a, b]) for a, b in zip(spec.differentials, gl.differentials))
        stack = None
        if gl.stack is not None:   # refraction may have widened the delta rays' stacks: pad with -1 (empty)
            a, b = spec.stack, gl.stack
            wdt = max(a.shape[1], b.shape[1])
            a, b = (np.pad(x, ((0, 0), (0, wdt - x.shape[1])), constant_values=-1) for x in (a, b))
            stack = np.concatenate([a, b])
        return RayBatch(np.concatenate([spec.origins, gl.origins]), np.concatenate([spec.directions, gl.directions]),
                        sample=np.concatenate([spec.sample, gl.sample]),
                        throughput=np.concatenate([spec.throughput, gl.throughput]), differentials=diffs,
                        stack=stack, bsdf_pdf=np.concatenate([np.zeros(spec.size), gl.bsdf_pdf]))

    def _spawn_glossy(self, surf, thr_h, s_idx, dsub, stack_h, gidx, depth, rng):
        """``n`` BSDF-sampled rays per hit ``gidx`` (stratified), or None when none survives: reflections, and
        transmissions through materials that declare ``transmits`` (rough glass)."""
        nb = self.n_glossy(depth)
        src = np.repeat(gidx, nb)
        sub = surf.subset(src)
        u = stratified_samples(stream_rows(rng, gidx), gidx.size, nb).transpose(1, 0, 2).reshape(-1, 2)
        wi, weight, pdf = BSDFBatch(sub, self.scene.materials).sample(np.arange(src.size), u)
        t_new = take_rows(thr_h, src) * weight / nb
        # below the geometric surface a reflected ray would enter the object (dropped, as for mirrors); for a
        # transmitting material (rough glass) a ray below it is a refraction and goes on through the interface
        below = dot(wi, sub.ng) <= 0
        transmits = self.ps.transmits[sub.material_id]
        refr_all = below & transmits
        above, t_new = roulette.survivors(t_new, self.throughput_cutoff, rng if self.roulette else None)
        alive = (pdf > 0) & above & (~below | refr_all)
        keep = np.flatnonzero(alive)
        if keep.size == 0:
            return None
        c = sub.subset(keep)
        w = normalize_rows(take_rows(wi, keep))
        diffs = None
        if dsub is not None:   # the differentials' terms once per hit (nb rays share them), then per ray
            terms = reflect_differential_terms(surf.subset(gidx), take_rows(dsub[1], gidx), take_rows(dsub[3], gidx))
            ox, dx, oy, dy = (take_rows(t, keep // nb) for t in terms)     # src = repeat(gidx, nb)
            dx += w
            dy += w
            diffs = (ox, dx, oy, dy)
        stack = None
        if stack_h is not None:
            stack = self.ps.media.spawn_stacks(stack_h, surf.material_id, surf.front, src[keep], refr_all[keep])
        return RayBatch(self.offset(c, w), w, sample=np.take(s_idx, src[keep]), throughput=take_rows(t_new, keep),
                        differentials=diffs, stack=stack, bsdf_pdf=nb * pdf[keep])
