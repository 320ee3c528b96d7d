"""The light family's compiled form: type tags, parameter records and the per-hit light sample.

A light the compiled tile kernel can sample packs itself into one row of the light table
(:meth:`pyrt.lights.Light.compiled_record`): a tag and a float64 record of :data:`RECORD` entries:

=========  =====================================================================================================
POINT      0-2 position, 6-8 intensity I (W/sr, RGB), 13 distance-falloff kind (:data:`pyrt.shaders.jit.
           DISTANCE_KINDS`), 14 epsilon, 15 range (inf: none), 16-18 clq (Kc, Kl, Kq)
SPOT       as POINT, plus 3-5 unit axis, 9 cos inner, 10 cos outer, 11 spot-falloff kind (:data:`pyrt.shaders.
           jit.SPOT_KINDS`)
DIRECT     3-5 unit direction the light travels, 6-8 irradiance E (W/m^2, RGB)
=========  =====================================================================================================

:func:`sample_li` is :meth:`pyrt.lights.PointLight.sample_li` (and the spot's and directional light's) for one
shading point: ``E = scale * rgb`` toward ``wi`` from ``dist`` away (``inf`` for directional light).
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

from pyrt.shaders import jit as J

#: parameters per light record
RECORD = 20
#: type tags
POINT, SPOT, DIRECTIONAL = 1, 2, 3


@register_jitable(inline="always")
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


@register_jitable(inline="always")
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


@register_jitable(inline="always")
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
