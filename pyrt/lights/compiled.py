"""The light family's compiled form: type tags, parameter records and the per-hit light sample.

A light the compiled tile kernel can sample packs itself into one row of the light table
(:meth:`pyrt.lights.Light.compiled_record`): a tag and a float64 record of :data:`RECORD` entries:

=========  =====================================================================================================
POINT      0-2 position, 6-8 intensity I (W/sr, RGB), 13 distance-falloff kind (:data:`pyrt.shaders.jit.
           DISTANCE_KINDS`), 14 epsilon, 15 range (inf: none), 16-18 clq (Kc, Kl, Kq)
SPOT       as POINT, plus 3-5 unit axis, 9 cos inner, 10 cos outer, 11 spot-falloff kind (:data:`pyrt.shaders.
           jit.SPOT_KINDS`)
DIRECT     3-5 unit direction the light travels, 6-8 irradiance E (W/m^2, RGB)
RECT       0-2 centre, 3-5 unit normal (the emitting side), 6-8 radiance L (W m^-2 sr^-1, RGB, ``color`` applied),
           9-11 tangent (the width's direction), 12-14 bitangent, 15 width, 16 height, 17 area, 18 samples per hit
DISK       as RECT with 15 radius (16 unused)
SPHERE     0-2 centre, 6-8 radiance, 15 radius, 17 area, 18 samples per hit
           (every area light: 19 BSDF samples per hit, combined with the light samples by the power heuristic;
           20 1 where its visible emitter mesh is in the scene, :data:`TRACED`)
ENV        0 light samples, 1 BSDF samples per hit (:class:`pyrt.EnvironmentLight` with ``strategy="mis"``), 2 1 where
           the glossy integrator samples its map at glossy hits (0: it leaves the environment to the glossy rays)
MESH       the emissive triangles of the scene's meshes (:class:`pyrt.EmissiveMeshLight`): 0 where its tables start in
           the light table's flat data, 1-4 their sizes, 18 samples per hit (:mod:`pyrt.lights.compiled_mesh`)
=========  =====================================================================================================

:func:`sample_li` is :meth:`pyrt.lights.PointLight.sample_li` (and the spot's and directional light's) for one
shading point: ``E = scale * rgb`` toward ``wi`` from ``dist`` away (``inf`` for directional light).
:func:`area_sample` is the area lights' :meth:`~pyrt.lights.RectLight.sample` (rectangle and disk uniform by area,
the sphere uniform in the cone it subtends) for one shading point and one pair of random numbers: ``E = scale * L``.
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

from pyrt.materials.compiled_sampling import coordinate_frame, square_to_uniform_disk_concentric
from pyrt.shaders import jit as J

#: parameters per light record
RECORD = 21
#: where an area light's record says that its visible emitter mesh is in the scene: glossy rays reach it, so the
#: glossy integrator weighs its light samples at glossy hits against them (:mod:`pyrt.integrators.glossy`)
TRACED = 20
#: type tags
POINT, SPOT, DIRECTIONAL = 1, 2, 3
#: the area lights' tags (:data:`RECT` to :data:`SPHERE`; :data:`ENV` and :data:`MESH` after them are not)
RECT, DISK, SPHERE = 4, 5, 6
#: where an area light's record holds its samples per hit
AREA_SAMPLES = 18
#: the environment light (``strategy="mis"``): record 0 light samples, 1 BSDF samples per hit; the environment
#: itself is the kernel's (:mod:`pyrt.lights.compiled_env`, packed once per scene)
ENV = 7
#: the emissive-mesh light (:mod:`pyrt.lights.compiled_mesh`; not an area light: its tables follow the records)
MESH = 8


@register_jitable(forceinline=True)
def light_record(pars, j):
    """The fields of light ``j``'s record (``pars`` the record table's flat data,
    :func:`pyrt.core.unmanaged.pointer`: its record at ``j * RECORD``) that :func:`sample_li_record` reads, as a
    tuple: position, axis / direction, distance-falloff kind, epsilon, range, Kc, Kl, Kq, spot-falloff kind, cos
    inner, cos outer. Read once per light before a loop over a packet's lanes: a loop that reads the table itself
    cannot keep the values in registers (its stores might overwrite them, as far as the compiler knows) and does
    not vectorise."""
    b = j * RECORD
    return (pars[b], pars[b + 1], pars[b + 2], pars[b + 3], pars[b + 4], pars[b + 5], int(pars[b + 13]),
            pars[b + 14], pars[b + 15], pars[b + 16], pars[b + 17], pars[b + 18], int(pars[b + 11]), pars[b + 9],
            pars[b + 10])


@register_jitable(forceinline=True)
def sample_li_record(tag, kind, rec, px, py, pz):
    """:func:`sample_li` from the light's :func:`light_record` ``rec`` and its distance-falloff kind ``kind``
    (``rec[6]``, or that value as a constant: a loop over many points for one light passes it so, and the falloff's
    switch over the kinds folds away)."""
    if tag == DIRECTIONAL:
        return -rec[3], -rec[4], -rec[5], math.inf, 1.0
    dx, dy, dz = rec[0] - px, rec[1] - py, rec[2] - pz
    dist = math.sqrt(dx * dx + dy * dy + dz * dz)
    inv = 1.0 / dist if dist > 0.0 else 0.0
    wx, wy, wz = dx * inv, dy * inv, dz * inv
    s = J.distance_falloff(kind, dist, rec[7], rec[8], rec[9], rec[10], rec[11])
    if tag == SPOT and s > 0.0:
        cos_theta = -(wx * rec[3] + wy * rec[4] + wz * rec[5])
        s *= J.spot_falloff(rec[12], cos_theta, rec[13], rec[14])
    return wx, wy, wz, dist, s


@register_jitable(forceinline=True)
def sample_li(tag, pars, j, px, py, pz):
    """Sample light ``j`` (tag ``tag``; ``pars`` the record table's flat data, :func:`pyrt.core.unmanaged.pointer`:
    its record at ``j * RECORD``) from the point ``p``: ``(wx, wy, wz, dist, scale)``, ``w`` the unit direction toward
    the light, the irradiance ``E = scale * (record[6], record[7], record[8])`` (scale 0: no light, and no shadow ray
    to trace)."""
    rec = light_record(pars, j)
    return sample_li_record(tag, rec[6], rec, px, py, pz)


def punctual_record(light, tag):
    """The record of a point or spot light (position, RGB intensity and the distance falloff)."""
    rec = np.zeros(RECORD)
    rec[0:3] = light.position
    rec[6:9] = light.I
    rec[13] = J.DISTANCE_KINDS.index(light.falloff)
    rec[14] = light.epsilon or 0.0
    rec[15] = np.inf if light.range is None else light.range
    rec[16:19] = light.clq or (0.0, 0.0, 1.0)
    return tag, rec


@register_jitable(forceinline=True)
def area_sample(tag, pars, j, px, py, pz, u0, u1):
    """Sample area light ``j`` (tag :data:`RECT`, :data:`DISK` or :data:`SPHERE`) from the point ``p`` with the
    random numbers ``(u0, u1)``: ``(wx, wy, wz, dist, scale)``, the irradiance ``E = scale * L`` (the record's
    radiance at 6-8), ``dist`` the distance to the sampled point along the unit ``w``. The same arithmetic as the
    lights' NumPy :meth:`sample` (:func:`pyrt.lights.area._planar_sample`: ``scale = max(0, -w.n) A / r^2``; the
    sphere's ``2 pi (1 - cos theta_max)``, zero inside it)."""
    b = j * RECORD
    cx, cy, cz = pars[b], pars[b + 1], pars[b + 2]
    if tag == SPHERE:
        r = pars[b + 15]
        dcx, dcy, dcz = cx - px, cy - py, cz - pz
        dist_c = math.sqrt(dcx * dcx + dcy * dcy + dcz * dcz)
        outside = dist_c > r * (1.0 + 1e-9)
        inv = 1.0 / dist_c if dist_c > 0.0 else 0.0
        wc = (dcx * inv, dcy * inv, dcz * inv)
        sin2 = min(max((r * inv) ** 2, 0.0), 1.0)
        one_minus_cos = sin2 / (1.0 + math.sqrt(1.0 - sin2)) if outside else 0.0
        cos_max = 1.0 - one_minus_cos
        z = 1.0 - u0 * (1.0 - cos_max)
        rr = math.sqrt(max(0.0, 1.0 - z * z))
        phi = 2.0 * math.pi * u1
        lx, ly = rr * math.cos(phi), rr * math.sin(phi)
        a0, a1, a2 = wc
        if not outside:
            a0, a1, a2 = 0.0, 0.0, 1.0
        s_, t_ = coordinate_frame(a0, a1, a2)
        w0 = lx * s_[0] + ly * t_[0] + z * wc[0]
        w1 = lx * s_[1] + ly * t_[1] + z * wc[1]
        w2 = lx * s_[2] + ly * t_[2] + z * wc[2]
        bb = w0 * dcx + w1 * dcy + w2 * dcz
        disc = max(bb * bb - (dist_c * dist_c - r * r), 0.0)
        dist = max(bb - math.sqrt(disc), 0.0)
        return w0, w1, w2, dist, 2.0 * math.pi * one_minus_cos
    if tag == RECT:
        a0, a1 = (u0 - 0.5) * pars[b + 15], (u1 - 0.5) * pars[b + 16]
    else:
        q0, q1 = square_to_uniform_disk_concentric(u0, u1)
        a0, a1 = q0 * pars[b + 15], q1 * pars[b + 15]
    x0 = cx + a0 * pars[b + 9] + a1 * pars[b + 12]
    x1 = cy + a0 * pars[b + 10] + a1 * pars[b + 13]
    x2 = cz + a0 * pars[b + 11] + a1 * pars[b + 14]
    d0, d1, d2 = x0 - px, x1 - py, x2 - pz
    dist = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    inv = 1.0 / dist if dist > 0.0 else 0.0
    w0, w1, w2 = d0 * inv, d1 * inv, d2 * inv
    cos_l = max(-(w0 * pars[b + 3] + w1 * pars[b + 4] + w2 * pars[b + 5]), 0.0)
    return w0, w1, w2, dist, cos_l * pars[b + 17] * inv * inv


@register_jitable
def area_pdf_dist(tag, pars, j, px, py, pz, wx, wy, wz):
    """Where the ray ``p + t w`` (``t > 0``) meets area light ``j``'s emitting surface: ``(pdf, dist)``, the
    solid-angle density of :func:`area_sample` toward ``w`` (:meth:`pyrt.lights.RectLight.pdf_li` and the disk's and
    sphere's) and the distance (:meth:`~pyrt.lights.RectLight.ray_distance`; ``inf`` and pdf 0 where it misses: the
    back of a rectangle or disk, outside the sphere's cone, or ``p`` inside the sphere)."""
    b = j * RECORD
    cx, cy, cz = pars[b], pars[b + 1], pars[b + 2]
    if tag == SPHERE:
        r = pars[b + 15]
        dcx, dcy, dcz = cx - px, cy - py, cz - pz
        cc = dcx * dcx + dcy * dcy + dcz * dcz
        dist_c = math.sqrt(cc)
        outside = dist_c > r * (1.0 + 1e-9)
        inv = 1.0 / dist_c if dist_c > 0.0 else 0.0
        sin2 = min(max((r * inv) ** 2, 0.0), 1.0)
        one_minus_cos = sin2 / (1.0 + math.sqrt(1.0 - sin2)) if outside else 0.0
        bb = wx * dcx + wy * dcy + wz * dcz
        pdf = 1.0 / (2.0 * math.pi * one_minus_cos) if outside and bb * inv >= 1.0 - one_minus_cos else 0.0
        c = cc - r * r
        disc = bb * bb - c
        t = bb - math.sqrt(max(disc, 0.0))
        return pdf, (t if disc >= 0.0 and c > 0.0 and t > 0.0 else math.inf)
    nx, ny, nz = pars[b + 3], pars[b + 4], pars[b + 5]
    cos_l = -(wx * nx + wy * ny + wz * nz)
    t = ((cx - px) * nx + (cy - py) * ny + (cz - pz) * nz) / -cos_l if cos_l > 0.0 else -1.0
    if not (cos_l > 0.0 and t > 0.0):
        return 0.0, math.inf
    x0, x1, x2 = px + t * wx - cx, py + t * wy - cy, pz + t * wz - cz
    if tag == RECT:
        inside = (abs(x0 * pars[b + 9] + x1 * pars[b + 10] + x2 * pars[b + 11]) <= 0.5 * pars[b + 15]
                  and abs(x0 * pars[b + 12] + x1 * pars[b + 13] + x2 * pars[b + 14]) <= 0.5 * pars[b + 16])
    else:
        inside = x0 * x0 + x1 * x1 + x2 * x2 <= pars[b + 15] ** 2
    if not inside:
        return 0.0, math.inf
    return t * t / cos_l / pars[b + 17], t


@register_jitable(forceinline=True)
def stratum(s, ns, k, x0, x1, perm):
    """Sample ``s`` of a hit's ``ns`` light samples in [0, 1)^2 (:func:`pyrt.core.sampler.stratified_samples`): the
    cell ``(s % k, s // k)`` of the ``k x k`` jittered grid when ``ns = k^2``, else the Latin-hypercube strata ``s``
    and ``perm`` (the hit's permutation of ``range(ns)`` at ``s``), jittered by ``(x0, x1)``."""
    if ns == 1:
        return x0, x1
    if k * k == ns:
        return (s % k + x0) / k, (s // k + x1) / k
    return (s + x0) / ns, (perm + x1) / ns


def area_record(light, tag):
    """The record of a rectangle, disk or sphere light (:data:`RECT`, :data:`DISK`, :data:`SPHERE`)."""
    rec = np.zeros(RECORD)
    rec[0:3] = light.center
    rec[6:9] = light.L
    if tag != SPHERE:
        rec[3:6] = light.normal
        rec[9:12] = light.tangent
        rec[12:15] = light.bitangent
    if tag == RECT:
        rec[15:17] = light.size
    else:
        rec[15] = light.radius
    rec[17] = light.area
    rec[AREA_SAMPLES] = light.n_samples
    rec[AREA_SAMPLES + 1] = light.bsdf_samples
    return tag, rec
