"""The direct-lighting estimator: the integrators own it; lights only sample, materials only evaluate.

For every light at every hit that can receive light, :func:`estimate` returns the reflected radiance
``L = int f(wo, wi) L_i(wi) V(wi) cos theta_i dwi`` (N, 3) toward the viewer:

- punctual and area lights by light sampling (:func:`light_sampling_estimate`: ``sample_li`` of the
  light, one shadow ray per sample where light, BSDF and side allow), as pbrt-v4's ``SampleLd``;
- environment lights (``light.environment`` set) by the strategy the light names
  (:func:`environment_estimate`): uniform, cosine, map (light sampling), bsdf (the materials'
  ``sample``), mis (``n_samples`` light and ``bsdf_samples`` BSDF samples, power or balance heuristic with
  the counts, optionally from the MIS-compensated table) or the unshadowed ``preview``; with the light's
  ``control_variate`` (off by default) Lambertian hits on flat faces get the unshadowed irradiance ``albedo / pi E(n)``
  exactly and their samples add ``(V - 1)`` times their value (:func:`control_variate_hits`).

``bsdf`` is a :class:`pyrt.materials.dispatch.BSDFBatch` over the hits (``f_cos``, ``sample``, ``pdf`` in
world space); ``visible(idx, wi, dist, end=None)`` traces shadow rays from hits ``idx`` and returns a
bool array, or with transparent shadows a transmittance (k, 3) (:meth:`pyrt.integrators.whitted.Integrator.
visibility`; :func:`_shadowed` and :func:`_shadowed_values` apply either); ``rng`` is the chunk's generator.
Random numbers are drawn in a fixed order per light, so a seed gives a bit-identical image.
"""
from __future__ import annotations

import numpy as np

from pyrt.core.sampler import stratified_samples
from pyrt.shaders import dfg
from pyrt.shaders import envmap as K
from pyrt.shaders import sampling
from pyrt.shaders.vec import dot, max_component, put_rows, take_rows

#: at most this many distinct normals of one batch get the control variate (the ones with the most hits, ties in
#: the order of :func:`distinct_rows`): bounds the quadratures a batch can ask for (each ~0.05-3 ms, once per
#: process and normal) on finely faceted flat-shaded meshes; the rest keep the plain estimate. The choice depends
#: on the batch alone (not on what was computed before), so images do not depend on the worker count.
CV_MAX_NORMALS = 64
_HASH = (np.uint64(0x9E3779B97F4A7C15), np.uint64(0xC2B2AE3D27D4EB4F))


def estimate(lights, surf, bsdf, visible, rng):
    """Direct light (N, 3) from every light in ``lights`` at the hits of ``surf`` (summed in order).

    One accumulator for all lights: a light sampled once per hit (every delta light) adds its lit lanes into
    it in place, with no (N, 3) array of its own to zero, divide by one sample and add; per hit the sum runs in
    light order as before (adding the zeros of unlit lanes changed nothing), so images are bit-identical.
    Consecutive delta lights share one shadow query (:func:`delta_lights_estimate`).
    """
    L = np.zeros((surf.n_hits, 3))
    run = []                     # consecutive delta lights of one sample: one shadow query, added in order
    for light in lights:
        if light.delta and light.environment is None and light.n_samples == 1 and not light.bsdf_samples:
            run.append(light)
            continue
        if run:
            delta_lights_estimate(run, surf, bsdf, visible, L)
            run = []
        if light.environment is None and light.n_samples == 1 and not light.bsdf_samples:
            light_sampling_estimate(light, surf, bsdf, visible, rng, out=L)
        else:
            L += estimate_light(light, surf, bsdf, visible, rng)
    if run:
        delta_lights_estimate(run, surf, bsdf, visible, L)
    return L


def shadow_queries(visible, surf, queries):
    """The results of ``visible(idx, wi, dist, end)`` for several ``queries`` (tuples of those arguments, e.g. one
    per light) from one call: the rays are concatenated (the end points made per-ray where the lights differ) and
    the result split again. Each ray's answer is what its own query gives (every shadow ray is traced and offset
    on its own), with a fraction of the per-query cost: one origin computation, one Embree call, and for
    transparent shadows one walk through the see-through surfaces instead of one per light."""
    if len(queries) == 1:
        return [visible(*queries[0])]
    sizes = [q[0].size for q in queries]
    idx = np.concatenate([q[0] for q in queries])
    wi = np.concatenate([q[1] for q in queries])
    dist = np.concatenate([np.asarray(q[2], dtype=np.float64) for q in queries])
    end = None
    if any(q[3] is not None for q in queries):    # per-ray end points; NaN: p + wi dist (Strategy.shadow)
        end = np.full((idx.size, 3), np.nan)
        lo = 0
        for q, k in zip(queries, sizes):
            if q[3] is not None:
                end[lo:lo + k] = q[3]
            lo += k
    vis = visible(idx, wi, dist, end)
    cuts = np.cumsum(sizes)[:-1]
    return np.split(vis, cuts)


def delta_lights_estimate(lights, surf, bsdf, visible, out):
    """Add the direct light of the delta ``lights`` (one sample per hit each) into ``out`` (N, 3), in light order:
    what :func:`light_sampling_estimate` adds light by light, with every light's shadow rays in one query
    (:func:`shadow_queries`; the BSDF is still queried per light). Bit-identical to the light-by-light sum."""
    n = surf.n_hits
    u = np.zeros((n, 2))
    parts, queries = [], []
    for light in lights:
        ls = light.sample_li(surf.p, u)
        lit = _lit_lanes(ls, surf, bsdf)
        if lit is None:
            continue
        idx, wi_a, f = lit
        parts.append((ls, idx, f))
        queries.append((idx, wi_a, np.take(ls.dist, idx), light.position if light.fixed_position else None))
    if not parts:
        return out
    for (ls, idx, f), vis in zip(parts, shadow_queries(visible, surf, queries)):
        idx, f = _shadowed(vis, idx, f)
        ls.weight(f, idx)
        put_rows(out, idx, take_rows(out, idx) + f)
    return out


def estimate_light(light, surf, bsdf, visible, rng):
    """Direct light (N, 3) from one light: the environment estimator or light sampling."""
    if light.environment is not None:
        return environment_estimate(light, surf, bsdf, visible, rng)
    if light.bsdf_samples and not light.delta:
        return area_mis_estimate(light, surf, bsdf, visible, rng)
    return light_sampling_estimate(light, surf, bsdf, visible, rng)


def area_mis_estimate(light, surf, bsdf, visible, rng):
    """Direct light (N, 3) from a non-delta light with ``bsdf_samples > 0`` (area lights): ``n_l = n_samples``
    light samples (:func:`light_sampling_estimate`) and ``n_b = bsdf_samples`` BSDF samples (stratified), the
    latter reaching the light where :meth:`Light.ray_distance` is finite, each traced to ``1 - 1e-4`` of that
    distance like a light sample; weights ``w_l``, ``w_b`` of the power heuristic with the counts (they sum to
    1), each technique divided by its count. The light's radiance ``light.L`` is constant over its surface.
    """
    n_l, n_b = light.n_samples, light.bsdf_samples

    def w_light(idx, wi, pdf=None):
        """MIS weight of the light samples that reach the light."""
        return sampling.power_heuristic(light.pdf_li(take_rows(surf.p, idx), wi), bsdf.pdf(idx, wi), 2.0, n_l, n_b)
    L = light_sampling_estimate(light, surf, bsdf, visible, rng, weight=w_light)
    n = surf.n_hits
    acc = np.zeros((n, 3))
    all_idx = np.arange(n)
    us = stratified_samples(rng, n, n_b)
    for s in range(n_b):
        wi, weight, pdf_b = bsdf.sample(all_idx, us[s])
        idx = np.flatnonzero(surf.light_side(wi) & (pdf_b > 0) & (max_component(weight) > 0))
        if idx.size == 0:
            continue
        p, w = take_rows(surf.p, idx), take_rows(wi, idx)
        dist = light.ray_distance(p, w)
        hit = np.flatnonzero(np.isfinite(dist))
        if hit.size == 0:
            continue
        idx, p, w, dist = idx[hit], take_rows(p, hit), take_rows(w, hit), dist[hit]
        w_b = sampling.power_heuristic(pdf_b[idx], light.pdf_li(p, w), 2.0, n_b, n_l)
        val = take_rows(weight, idx) * np.asarray(light.L, dtype=np.float64)[None, :] * w_b[:, None]
        keep = np.flatnonzero(max_component(val) > 0)
        if keep.size == 0:
            continue
        idx, w, dist, val = idx[keep], take_rows(w, keep), dist[keep], take_rows(val, keep)
        vis = visible(idx, w, dist)
        put_rows(acc, idx, take_rows(acc, idx) + _shadowed_values(vis, val))
    return L + acc / n_b



def light_sampling_estimate(light, surf, bsdf, visible, rng, weight=None, out=None):
    """Direct light (N, 3) from ``light`` toward ``surf.wo`` at every hit of ``surf``, by light sampling.

    ``light.n_samples`` samples per hit (stratified for non-delta lights), each one shadow ray where the
    light can contribute: on the light's side of the surface (``surf.light_side``), ``E > 0`` and a
    non-zero BSDF. ``weight(idx, wi, pdf) -> (k,)``, if given, multiplies each unoccluded sample (the MIS weight
    of light sampling when another strategy also reaches the light, :mod:`pyrt.integrators.glossy`); ``pdf`` is
    the samples' own density (:attr:`LightSample.pdf`) or None (then ``light.pdf_li`` of the direction).
    ``out`` (N, 3), for a light with one sample per hit: the contributions are added into it in place and
    it is returned (:func:`estimate`'s accumulator).
    """
    n = surf.n_hits
    ns = light.n_samples
    if out is not None and ns != 1:
        raise ValueError(f"light_sampling_estimate: out= needs one sample per hit, {light.label} has {ns}")
    L = np.zeros((n, 3)) if out is None else out
    # delta lights ignore u; others get stratified samples (jittered grid or Latin hypercube)
    us = np.zeros((ns, n, 2)) if light.delta else stratified_samples(rng, n, ns)
    for s in range(ns):
        u = us[s]
        ls = light.sample_li(surf.p, u)
        lit = _lit_lanes(ls, surf, bsdf)
        if lit is None:
            continue
        idx, wi_a, f = lit
        vis = visible(idx, wi_a, np.take(ls.dist, idx), light.position if light.fixed_position else None)
        if weight is not None:    # MIS against the glossy integrator's BSDF rays: the weight of each lit lane
            lit = np.flatnonzero(vis if vis.ndim == 1 else max_component(vis) > 0)
            pdf_lit = None if ls.pdf is None else np.take(ls.pdf, idx[lit])
            w_lit = weight(idx[lit], take_rows(wi_a, lit), pdf_lit)
        idx, f = _shadowed(vis, idx, f)
        if weight is not None:
            f = f * w_lit[:, None]
        ls.weight(f, idx)
        put_rows(L, idx, take_rows(L, idx) + f)
    return L if out is not None else L / ns


def _lit_lanes(ls, surf, bsdf):
    """``(idx, wi (k, 3), f_cos (k, 3))`` of the hits the light sample ``ls`` can light before shadowing: on the
    light's side (``ng . wi > 0``, or the interpolated vertex normal faces the light: the shadow terminator,
    :mod:`pyrt.geometry.offsets`), ``E > 0`` and a non-zero BSDF; None where there is none."""
    wi = ls.wi
    if ls.factored:          # E = scale * rgb: no (N, 3) irradiance array
        if not np.max(ls.rgb) > 0:
            return None
        active = surf.light_side(wi)
        if ls.scale is not None:
            active &= ls.scale > 0
    else:
        active = surf.light_side(wi) & (max_component(ls.E) > 0)
    idx = np.flatnonzero(active)
    if idx.size == 0:
        return None
    wi_a = take_rows(wi, idx)
    f = bsdf.f_cos(idx, wi_a)
    nonzero = max_component(f) > 0
    if not nonzero.all():                  # (np.flatnonzero keeps the GIL: only when needed)
        keep = np.flatnonzero(nonzero)
        if keep.size == 0:
            return None
        idx, f, wi_a = idx[keep], take_rows(f, keep), take_rows(wi_a, keep)
    return idx, wi_a, f


def _shadowed(vis, idx, f):
    """The rows ``idx`` and values ``f`` (k, 3) that light reaches: a bool ``vis`` (k,) keeps the unblocked
    rows; a transmittance (k, 3) (transparent shadows) scales them and drops the rows it zeroes."""
    if vis.ndim == 1:
        keep = np.flatnonzero(vis)
        return idx[keep], take_rows(f, keep)
    keep = np.flatnonzero(max_component(vis) > 0)
    return idx[keep], take_rows(f, keep) * take_rows(vis, keep)


def _shadowed_values(vis, val):
    """``val`` (k, 3) where unblocked (bool ``vis``), or scaled by the transmittance ``vis`` (k, 3)."""
    if vis.ndim == 1:
        return np.where(vis[:, None], val, 0.0)
    return val * vis


def distinct_rows(a):
    """``(rows (m, 3), inverse (k,))`` of the distinct rows of a float64 ``a`` (k, 3) (``rows[inverse] == a``), in
    a deterministic order: one row when all are equal (an upward-facing plane), else rows grouped by a 64-bit hash
    of their bits (``np.unique`` on integers, 10x cheaper than on rows), checked, ``np.unique(axis=0)`` on a
    collision."""
    if (a == a[0]).all():
        return a[:1], np.zeros(a.shape[0], dtype=np.int64)
    bits = np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)
    key = (bits[:, 0] * _HASH[0] + bits[:, 1]) * _HASH[1] + bits[:, 2]    # wraps modulo 2^64
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    rows = take_rows(a, first)
    if (take_rows(rows, inv) == a).all():
        return rows, inv.reshape(-1)
    rows, inv = np.unique(a, axis=0, return_inverse=True)
    return rows, inv.reshape(-1)


def control_variate_hits(light, surf, bsdf):
    """The hits the control variate applies to and what it adds there, or None (off, or no such hit).

    Hits of Lambertian materials (``material.lambertian``) on flat faces (``surf.smooth`` False and the shading
    normal equal to the geometric one: no normal map) seen from the front (``n.wo > 0``), there ``f cos =
    albedo / pi max(0, n.wi)`` and the sampled domain ``n.wi > 0`` is its whole support. Their distinct normals
    (:func:`distinct_rows`), at most :data:`CV_MAX_NORMALS` of them per batch, get ``E(n)`` from
    :meth:`pyrt.lights.environment.Environment.irradiance` (cached per normal).

    Returns ``(mask (N,) bool, idx (k,), base (k, 3))``: ``base = albedo / pi E(n)`` at the hits ``idx``.
    """
    if not light.control_variate:
        return None
    lam = np.array([m.lambertian for m in bsdf.materials], dtype=bool)
    if not lam.any():
        return None
    idx = np.flatnonzero(lam[surf.material_id])
    if idx.size == 0:
        return None
    ns = take_rows(surf.ns, idx)
    flat = (ns == take_rows(surf.ng, idx)).all(axis=1) & (dot(ns, take_rows(surf.wo, idx)) > 0)
    if surf.smooth is not None:
        flat &= ~np.take(surf.smooth, idx)
    if not flat.all():
        keep = np.flatnonzero(flat)
        if keep.size == 0:
            return None
        idx, ns = idx[keep], take_rows(ns, keep)
    normals, inv = distinct_rows(ns)
    if normals.shape[0] > CV_MAX_NORMALS:
        top = np.argsort(-np.bincount(inv), kind="stable")[:CV_MAX_NORMALS]
        slot = np.full(normals.shape[0], -1)
        slot[top] = np.arange(top.size)
        inv = slot[inv]
        keep = np.flatnonzero(inv >= 0)
        idx, inv, normals = idx[keep], inv[keep], take_rows(normals, top)
    albedo = np.zeros((surf.n_hits, 3))
    for k in np.unique(surf.material_id[idx]):
        group = bsdf.groups[int(k)]      # the group's context: its texture lookups are the ones f_cos read
        put_rows(albedo, group.idx, bsdf.materials[k].albedo(group.ctx))
    E = take_rows(light.environment.irradiance(normals), inv)
    mask = np.zeros(surf.n_hits, dtype=bool)
    mask[idx] = True
    return mask, idx, take_rows(albedo, idx) / np.pi * E


def environment_estimate(light, surf, bsdf, visible, rng):
    """Image-based lighting (N, 3) at the hits of ``surf`` with the strategy of ``light``
    (a :class:`pyrt.EnvironmentLight`: ``strategy``, ``n_samples``, ``bsdf_samples``, ``heuristic``,
    ``compensate``, ``preview_samples``; see :mod:`pyrt.lights.environment_light`). Unbiased for every strategy
    but ``preview``.

    ``mis``: ``n_l = n_samples`` light samples (:meth:`EnvironmentLight.mis_sample`: the full or the
    compensated table) and ``n_b = bsdf_samples`` BSDF samples per hit, weighted by
    :meth:`EnvironmentLight.mis_weights` (``w_l + w_b = 1``), each divided by its own count. Random numbers
    per round ``s``: the light sample's ``u`` then the BSDF sample's (while ``s`` is below each count), the
    second coordinate stratified over the rounds of that technique.

    Control variate (``light.control_variate``, :func:`control_variate_hits`): at its hits every sample adds
    ``(V - 1) value`` instead of ``V value`` and the estimate gets ``albedo / pi E(n)``; other hits are computed
    exactly as without it (the same random numbers: the image of a seed changes only at those hits).
    """
    n = surf.n_hits
    if light.strategy == "preview":
        return _environment_preview(light, surf, bsdf)
    cv = control_variate_hits(light, surf, bsdf)
    cv_mask = None if cv is None else cv[0]
    env = light.environment
    ns = light.n_samples
    strategy = light.strategy
    mis = strategy == "mis"
    nb = light.bsdf_samples if mis else ns
    L_light = np.zeros((n, 3))
    # equal counts: one sum divided once (the image of a seed is the same as before the counts could differ)
    L_bsdf = L_light if nb == ns else np.zeros((n, 3))
    all_idx = np.arange(n)
    for s in range(max(ns, nb) if mis else ns):
        u = None
        if s < ns and strategy != "bsdf":
            u = rng.random((n, 2))
            u[:, 1] = (s + u[:, 1]) / ns     # stratify latitude (the table's marginal) / the 2nd warp dim
            if strategy == "uniform":
                wi = sampling.square_to_uniform_sphere(u)
                pdf = sampling.uniform_sphere_pdf(wi)
            elif strategy == "cosine":
                wl = sampling.square_to_cosine_hemisphere(u)
                wi = surf.to_world(wl)
                pdf = sampling.cosine_hemisphere_pdf(wl)
            elif strategy == "map":
                wi, pdf = env.sample(u)
            else:
                wi, pdf = light.mis_sample(u)
            _add_environment_sample(light, L_light, surf, bsdf, visible, wi, pdf, mis, cv_mask)
        if strategy == "bsdf" or (mis and s < nb):
            if mis:
                u = rng.random((n, 2))
                u[:, 1] = (s + u[:, 1]) / nb
            elif u is None:
                u = rng.random((n, 2))
                u[:, 1] = (s + u[:, 1]) / ns
            _add_bsdf_sample(light, L_bsdf, bsdf, surf, visible, all_idx, u, mis, cv_mask)
    L = L_light / ns if L_bsdf is L_light else L_light / ns + L_bsdf / nb
    if cv is not None:
        put_rows(L, cv[1], take_rows(L, cv[1]) + cv[2])
    return L


def _sample_values(vis, val, cv_mask, idx):
    """What samples of value ``val`` (k, 3) at hits ``idx`` with visibility ``vis`` add: ``V val``
    (:func:`_shadowed_values`), at the control variate's hits (``cv_mask`` (N,), or None) ``(V - 1) val``."""
    plain = _shadowed_values(vis, val)
    if cv_mask is None:
        return plain
    m = cv_mask[idx]
    if not m.any():
        return plain
    occluded = np.where(vis[:, None], 0.0, -val) if vis.ndim == 1 else val * (vis - 1.0)
    return occluded if m.all() else np.where(m[:, None], occluded, plain)


def _add_bsdf_sample(light, L_out, bsdf, surf, visible, all_idx, u, mis, cv_mask=None):
    """Add one BSDF-sampled direction per hit (random numbers ``u`` (N, 2)), MIS-weighted if ``mis``.

    Rows are gathered and scattered with :func:`take_rows` / :func:`put_rows` (``np.take`` / ``np.put`` of whole
    rows: cheaper than fancy indexing of (N, 3) arrays; the same numbers). ``cv_mask``: :func:`_sample_values`."""
    env = light.environment
    wi, weight, pdf_b = bsdf.sample(all_idx, u)
    ok = surf.light_side(wi) & (pdf_b > 0) & (max_component(weight) > 0)
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return
    w = take_rows(wi, idx)
    val = take_rows(weight, idx) * env.radiance(w)
    if mis:
        val *= light.mis_weights(light.mis_pdf(w), np.take(pdf_b, idx))[1][:, None]
    keep = np.flatnonzero(max_component(val) > 0)
    if keep.size < idx.size:
        idx, w, val = idx[keep], take_rows(w, keep), take_rows(val, keep)
    if idx.size:
        vis = visible(idx, w, np.full(idx.size, np.inf))
        put_rows(L_out, idx, take_rows(L_out, idx) + _sample_values(vis, val, cv_mask, idx))


def _add_environment_sample(light, L_out, surf, bsdf, visible, wi, pdf, mis, cv_mask=None):
    """Add one environment-sampled direction per hit (``pdf`` its density), MIS-weighted if ``mis`` (rows gathered
    and scattered as in :func:`_add_bsdf_sample`; ``cv_mask``: :func:`_sample_values`)."""
    # ng . wi > 0, or the shadow-terminator zone (see SurfaceBatch.light_side): the shadow ray decides
    idx = np.flatnonzero(surf.light_side(wi) & (pdf > 0))
    if idx.size == 0:
        return
    w = take_rows(wi, idx)
    Le = light.environment.radiance(w)
    lit = np.flatnonzero(max_component(Le) > 0)
    if lit.size < idx.size:
        idx, w, Le = idx[lit], take_rows(w, lit), take_rows(Le, lit)
    if idx.size == 0:
        return
    f = bsdf.f_cos(idx, w)
    p = np.take(pdf, idx)
    val = f * Le / p[:, None]
    if mis:
        val *= light.mis_weights(p, bsdf.pdf(idx, w))[0][:, None]
    keep = np.flatnonzero(max_component(val) > 0)
    if keep.size < idx.size:
        idx, w, val = idx[keep], take_rows(w, keep), take_rows(val, keep)
    if idx.size:
        vis = visible(idx, w, np.full(idx.size, np.inf))
        put_rows(L_out, idx, take_rows(L_out, idx) + _sample_values(vis, val, cv_mask, idx))


def _split_sum_preview(light, surf, bsdf, gi, L_out):
    """The split sum on the hits ``gi`` whose materials declare lobes (:meth:`Material.preview_lobes`): ``L_out``
    gets ``occlusion (diffuse E_SH(n) / pi + sum_lobes albedo x prefiltered(dominant direction, alpha))``; returns
    the hits left to the sampled estimate (materials without lobes)."""
    env = light.environment
    mids = surf.material_id
    rest = []
    for k in np.unique(mids[gi]):
        group = bsdf.groups[int(k)]   # every hit of material k (lambertian is per material): the group's
        sel, ctx = group.idx, group.ctx   # persistent context shares texture lookups with the other lights
        lobes = bsdf.materials[k].preview_lobes(ctx)
        if lobes is None:
            rest.append(sel)
            continue
        out = lobes.diffuse / np.pi * env.irradiance_sh(ctx.ns)
        for lobe in lobes.glossy:
            n = ctx.ns if lobe.normal is None else lobe.normal
            out += lobe.weight * env.prefiltered(dfg.dominant_direction(ctx.wo, n, lobe.alpha), lobe.alpha)
        if lobes.occlusion is not None:
            out *= lobes.occlusion[:, None]
        L_out[sel] = out
    return np.sort(np.concatenate(rest)) if rest else gi[:0]


def _environment_preview(light, surf, bsdf):
    """Unshadowed, noise-free approximation (``strategy="preview"``, see :mod:`pyrt.lights.environment`);
    ``bsdf`` is the :class:`BSDFBatch` of ``surf`` (its material groups are used)."""
    env = light.environment
    n = surf.n_hits
    L_out = np.zeros((n, 3))
    mids = surf.material_id
    # one flag per material, gathered per hit (not a Python loop over the hits)
    lambert = np.array([m.lambertian for m in bsdf.materials], dtype=bool)[mids]
    li = np.flatnonzero(lambert)
    if li.size:
        for k in np.unique(mids[li]):
            group = bsdf.groups[int(k)]
            L_out[group.idx] = bsdf.materials[k].albedo(group.ctx) / np.pi * env.irradiance_sh(group.ctx.ns)
    gi = np.flatnonzero(~lambert)
    if gi.size and light.preview_method == "split_sum":
        gi = _split_sum_preview(light, surf, bsdf, gi, L_out)
    if gi.size:
        # the K_ samples of every hit in one batch (rows k * m .. (k + 1) * m - 1: sample k), one BSDF query and
        # one prefiltered lookup instead of K_; summed in sample order as a loop over the samples would
        K_, m = light.preview_samples, gi.size
        pts = sampling.hammersley(K_)
        rows = np.tile(gi, K_)
        u = np.repeat(pts, m, axis=0)
        wi, weight, pdf = bsdf.sample(rows, u)
        cos_g = np.einsum("ij,ij->i", wi, take_rows(surf.ng, rows))
        ok = np.flatnonzero((cos_g > 0) & (pdf > 0))
        val = np.zeros((rows.size, 3))
        if ok.size:
            alpha = K.ggx_lobe_alpha_for_solid_angle(1.0 / (K_ * pdf[ok]))
            val[ok] = weight[ok] * env.prefiltered(wi[ok], alpha)
        acc = val[:m].copy()
        for k in range(1, K_):
            acc += val[k * m:(k + 1) * m]
        L_out[gi] = acc / K_
    return L_out
