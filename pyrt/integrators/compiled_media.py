"""Nested dielectrics and Beer-Lambert absorption on the compiled path: the interface stacks of
:mod:`pyrt.integrators.media` (Schmidt & Budge 2002) carried by the specular tree's rays.

Every row of the kernel's ray stack (:data:`pyrt.integrators.compiled_layout.STACK_ROW`) ends with its ray's interface
stack: the number of entries at :data:`~pyrt.integrators.compiled_layout.STACK_MED`, then up to
:data:`~pyrt.integrators.compiled_layout.MED_K` material ids in the order the ray entered them (the NumPy path's
``(N, K)`` rows). Each material record's :data:`pyrt.materials.compiled.MEDIUM` fields hold whether it takes part
(:func:`pyrt.integrators.media._participates`), its priority's dense rank, its index of refraction and its absorption
coefficient (:func:`medium_fields`). A scene without nested media or absorption (``NestedMedia.for_scene`` None)
carries no stack: ``opts[O_MEDIA]`` 0 and none of this runs.

At a hit of a popped ray (:func:`pyrt.integrators.compiled_kernel.trace_stack`) the same decisions as the NumPy path's
:meth:`~pyrt.integrators.media.NestedMedia.skip_false_hits`, ``attenuation``, ``eta_for_hits`` and
``spawn_stacks``, for one ray:

- :func:`classify`: a hit on a participating material is true or false, with the relative index ``eta_t / eta_i``;
- a false hit is crossed in a straight line (:func:`cross`: the stack pushed on entering, its most recent entry of
  the material removed on leaving), at most :data:`pyrt.integrators.media.MAX_FALSE_HITS` times (then the ray is
  dropped, as there);
- :func:`attenuation`: ``exp(-sigma_a d)`` of the current medium over the ray's length to its true hit (a miss: 0 in
  the channels that absorb, 1 in the others);
- :func:`spawned`: a spawned ray's stack is its parent's, crossed where it leaves below the geometric surface of a
  participating material.

The functions the kernel calls are compiled apart (not inlined: inlined, their loops cost the kernel's ray loop
registers even in scenes without media). The stack in hand is kept in the scratch row :data:`~pyrt.integrators.compiled_layout.MED_ROW` (the rows the ray's
children are pushed to overwrite its own). Where the NumPy path widens its stacks without bound, a ray that would enter
more than :data:`~pyrt.integrators.compiled_layout.MED_K` volumes at once is dropped (radiance 0; its count is set to
-1).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

from pyrt.geometry import embree_jit as E  # noqa: E402
from pyrt.integrators.compiled_coverage import cover_single  # noqa: E402
from pyrt.integrators.compiled_layout import MED_K, MED_ROW, STACK_MED, STACK_ROW, T_INF, _njit  # noqa: E402
from pyrt.integrators.media import MAX_FALSE_HITS, NestedMedia  # noqa: E402
from pyrt.materials import compiled as MC  # noqa: E402
from pyrt.shaders import jit as J  # noqa: E402
from pyrt.textures import is_texture  # noqa: E402

_own = numba.njit(nogil=True, cache=True, error_model="numpy")


def medium_fields(materials, records):
    """Fill the :data:`pyrt.materials.compiled.MEDIUM` fields of ``records`` (each ``(tag, record)`` of the material
    of the same index): whether it takes part in the interface stacks, its priority rank and ``ior`` (the
    :class:`pyrt.integrators.media.NestedMedia` tables), and the absorption coefficient of every dielectric with a
    constant one (what the transparent shadows absorb, nested or not). Returns whether the scene carries stacks
    (``NestedMedia.for_scene`` is not None)."""
    media = NestedMedia.for_scene(materials)
    for k, (m, (_, rec)) in enumerate(zip(materials, records)):
        b = MC.MEDIUM
        if media is not None and media.participates[k]:
            rec[b:b + 3] = [1.0, float(media.rank[k]), float(media.ior[k])]
        if m.is_dielectric and not is_texture(m.absorption):
            rec[b + 3:b + 6] = np.broadcast_to(np.asarray(m.absorption, dtype=np.float64), (3,))
    return media is not None


@_njit
def participates(pars, m):
    """Whether material ``m`` takes part in the interface stacks."""
    return pars[m * MC.RECORD + MC.MEDIUM] != 0.0


@_njit
def clear(stack, row):
    """An empty interface stack (vacuum) in row ``row``."""
    stack[row * STACK_ROW + STACK_MED] = 0.0


@_njit
def copy(stack, src, dst):
    """Row ``src``'s interface stack into row ``dst``."""
    a, b = src * STACK_ROW + STACK_MED, dst * STACK_ROW + STACK_MED
    for i in range(MED_K + 1):
        stack[b + i] = stack[a + i]


@_njit
def lost(stack, row):
    """Whether row ``row``'s ray overflowed its interface stack (dropped)."""
    return stack[row * STACK_ROW + STACK_MED] < 0.0


@_njit
def _last(stack, row, m):
    """The position of the most recent entry ``m`` of row ``row``'s stack, -1 if none."""
    b = row * STACK_ROW + STACK_MED
    for i in range(int(stack[b]) - 1, -1, -1):
        if int(stack[b + 1 + i]) == m:
            return i
    return -1


@_njit
def _top(stack, row, pars, skip):
    """The current medium of row ``row``'s stack without its entry at position ``skip`` (-1: none skipped): the entry
    of the highest rank, the most recent among equals (``NestedMedia.top``); -1 for vacuum."""
    b = row * STACK_ROW + STACK_MED
    best, best_rank = -1, -1.0
    for i in range(int(stack[b])):
        if i == skip:
            continue
        e = int(stack[b + 1 + i])
        r = pars[e * MC.RECORD + MC.MEDIUM + 1]
        if r >= best_rank:
            best, best_rank = e, r
    return best


@_njit
def _ior(pars, e):
    """The index of refraction of medium ``e`` (1: vacuum, ``e`` -1)."""
    return pars[e * MC.RECORD + MC.MEDIUM + 2] if e >= 0 else 1.0


@_own
def classify(stack, row, pars, m, front):
    """``(true hit, eta)`` of a hit on the participating material ``m`` from its front (``front``) or back, for the
    ray whose stack is row ``row`` (``NestedMedia.classify``): entering, true when ``m``'s rank is at least the
    current medium's; leaving, true when ``m`` is the current medium or not on the stack; ``eta = eta_t / eta_i``."""
    cur = _top(stack, row, pars, -1)
    j = _last(stack, row, m)
    n_m = _ior(pars, m)
    if front:
        r_cur = pars[cur * MC.RECORD + MC.MEDIUM + 1] if cur >= 0 else -1.0
        return cur < 0 or pars[m * MC.RECORD + MC.MEDIUM + 1] >= r_cur, n_m / _ior(pars, cur)
    if j < 0:
        return True, _ior(pars, cur) / n_m
    return cur == m, _ior(pars, _top(stack, row, pars, j)) / n_m


@_njit
def cross(stack, src, dst, m, front):
    """Row ``dst``'s stack: row ``src``'s after crossing the interface of ``m`` (``src`` may be ``dst``): ``m``
    pushed when entering (``front``; the count -1 when the stack is full: :func:`lost`), its most recent entry
    removed when leaving (none: unchanged)."""
    copy(stack, src, dst)
    b = dst * STACK_ROW + STACK_MED
    k = int(stack[b])
    if k < 0:
        return
    if front:
        if k >= MED_K:
            stack[b] = -1.0
            return
        stack[b + 1 + k] = m
        stack[b] = k + 1.0
        return
    j = _last(stack, dst, m)
    if j < 0:
        return
    for i in range(j, k - 1):
        stack[b + 1 + i] = stack[b + 2 + i]
    stack[b] = k - 1.0


@_own
def attenuation(stack, row, pars, dist):
    """Beer-Lambert transmittance ``exp(-sigma_a d)`` (RGB) of the current medium of row ``row``'s stack over the
    length ``dist`` (``inf`` for a miss: 0 where a channel absorbs, 1 where it does not), ``NestedMedia.attenuation``."""
    cur = _top(stack, row, pars, -1)
    if cur < 0:
        return 1.0, 1.0, 1.0
    b = cur * MC.RECORD + MC.MEDIUM + 3
    return _beer(pars[b], dist), _beer(pars[b + 1], dist), _beer(pars[b + 2], dist)


@_njit
def _beer(sigma, dist):
    """``exp(-sigma dist)``, 1 for ``sigma`` 0 whatever ``dist`` (:func:`pyrt.integrators.media.beer_lambert`)."""
    return math.exp(-(sigma * dist)) if sigma > 0.0 else 1.0


@_own
def spawned(stack, src, lo, hi, pars, m, front, ng):
    """The stacks of the rays pushed into rows ``[lo, hi)`` at a hit on material ``m`` (viewer-side geometric normal
    ``ng``, seen from its front or not) by a ray whose stack is row ``src``: the parent's, crossed where the ray
    leaves below the geometric surface of a participating material (``NestedMedia.spawn_stacks``, crossing by the
    direction, not the lobe: the NumPy path's rule)."""
    part = participates(pars, m)
    for r in range(lo, hi):
        b = r * STACK_ROW
        if part and stack[b + 3] * ng[0] + stack[b + 4] * ng[1] + stack[b + 5] * ng[2] < 0.0:
            cross(stack, src, r, m, front)
        else:
            copy(stack, src, r)


@_own
def skip_false(scene, G, fallback, mats_par, tex_tag, tex_par, layers, cover, stack, hit, prim, geom, u, v, o, d,
               ray_buf, V, lane, diffs):
    """The first true hit of the ray ``o + t d`` (unit ``d``) whose closest hit is ``(hit, prim, geom, u, v)`` and
    whose stack is in :data:`~pyrt.integrators.compiled_layout.MED_ROW` (``NestedMedia.skip_false_hits``): false hits
    crossed in a straight line (the stack crossed; the ray continued from the hit offset to its far side, as a
    refracted ray's origin; with ``cover`` culled faces skipped on the way, :func:`pyrt.integrators.compiled_coverage.
    cover_single`). Returns ``(hit, prim, geom, u, v, origin, length, ok, re-traced rays)``: the true hit (or miss),
    the origin of the ray's last segment and the length travelled before it; ``ok`` False for a ray dropped (still on a
    surface after :data:`~pyrt.integrators.media.MAX_FALSE_HITS` false hits, or more culled faces than ``layers``)."""
    wo = (-d[0], -d[1], -d[2])
    length = 0.0
    n_re = 0
    for _ in range(MAX_FALSE_HITS):
        if not hit:
            return hit, prim, geom, u, v, o, length, True, n_re
        m = G[8][G[7][geom] + prim]
        if not participates(mats_par, m):
            return hit, prim, geom, u, v, o, length, True, n_re
        p, ng, _, _, _, mag, _, front, _, _ = J.hit_surface(G, fallback, False, geom, prim, u, v, wo)
        if classify(stack, MED_ROW, mats_par, m, front)[0]:
            return hit, prim, geom, u, v, o, length, True, n_re
        length += math.sqrt((p[0] - o[0]) ** 2 + (p[1] - o[1]) ** 2 + (p[2] - o[2]) ** 2)
        cross(stack, MED_ROW, MED_ROW, m, front)
        o = J.round_away(p, mag, 1.0 if J.dot(d, ng) >= 0.0 else -1.0, ng)
        hit, _, prim, geom, u, v, _, _, _ = E.intersect1(scene, o[0], o[1], o[2], d[0], d[1], d[2], 0.0, T_INF,
                                                         ray_buf)
        n_re += 1
        if cover:
            hit, prim, geom, u, v, dropped, n_skip, _ = cover_single(scene, G, mats_par, tex_tag, tex_par, layers,
                                                                     False, hit, prim, geom, u, v, d, ray_buf, 0, V,
                                                                     lane, diffs)
            n_re += n_skip
            if dropped:
                return False, prim, geom, u, v, o, length, False, n_re
    return False, prim, geom, u, v, o, length, not hit, n_re


@_njit
def absorbed(pars, m, front, length):
    """A transparent shadow ray's Beer-Lambert factor (RGB) for a segment of ``length`` that ends on dielectric ``m``
    from its back (the ray was inside: :func:`pyrt.integrators.shadows._cross`; each dielectric bounded by vacuum);
    ones from its front."""
    if front:
        return 1.0, 1.0, 1.0
    b = m * MC.RECORD + MC.MEDIUM + 3
    return _beer(pars[b], length), _beer(pars[b + 1], length), _beer(pars[b + 2], length)


kernel_cache.restore()
