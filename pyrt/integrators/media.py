"""Nested dielectrics and absorption inside glass (Schmidt & Budge 2002).

C. M. Schmidt and B. Budge, "Simple Nested Dielectrics in Ray Traced Images", Journal of Graphics
Tools 7(2), 2002. Every dielectric material has a ``priority`` and encloses a medium (its index of
refraction and its absorption coefficient). Each ray carries an *interface stack*: the dielectric
materials whose volumes it is inside, in the order it entered them. The *current medium* is the
entry of highest priority (ties: the most recently entered); outside everything it is vacuum
(index 1, no absorption).

At a hit on a dielectric surface of material ``m``:

- entering ``m`` (the ray hits its outward side): a *true* hit when ``priority(m) >=`` the current
  medium's priority; the indices are ``eta_i`` = current medium's, ``eta_t`` = ``m``'s.
- leaving ``m``: a true hit when ``m`` is the current medium; ``eta_i`` = ``m``'s,
  ``eta_t`` = that of the medium that becomes current once ``m`` is removed. (If ``m`` is not on
  the stack at all - an open mesh, or geometry that starts around the camera - the hit is true with
  ``eta_t`` = the current medium's.)
- a *false* hit (a surface inside a volume of higher priority, e.g. the part of a water surface
  that lies inside the glass wall holding it) is ignored: the ray continues in a straight line
  through it with unchanged throughput, and only the stack is updated.
- refraction through a true hit pushes ``m`` (entering) or removes it (leaving); reflection keeps
  the stack.

Absorption (Beer-Lambert): along a segment of length ``d`` inside a medium of absorption
coefficient ``sigma_a`` (per scene unit, RGB) the throughput is multiplied by ``exp(-sigma_a d)``.

Cost model ("model no more than a scene needs"): :meth:`NestedMedia.for_scene` returns ``None``
unless the scene has more than one participating dielectric material or an absorbing one; only
then does the integrator carry a stack per ray (an ``(N, K)`` int32 array of material ids, ``-1`` =
empty, ``K`` grows when a ray is inside more volumes) and resolve false hits. A scene with one
non-absorbing glass renders exactly as without this module.

A material *participates* when ``is_dielectric`` is set and ``thin_walled`` is not, its ``ior`` is a number
(not a texture) and its ``delta_lobes`` accepts the keyword ``eta`` (the relative index ``eta_t / eta_i`` decided here),
like :class:`pyrt.materials.Glass`.
"""
from __future__ import annotations


import numpy as np

from pyrt.geometry.accel import Hits

#: false hits skipped per ray and bounce before the ray is dropped (deeply overlapping volumes)
MAX_FALSE_HITS = 32


def absorption_from_transmittance(color, distance):
    """Absorption coefficient ``sigma_a = -ln(color) / distance`` (RGB, per scene unit) of a medium
    that transmits the fraction ``color`` (in (0, 1]) of the light over ``distance``."""
    c = np.asarray(color, dtype=np.float64)
    c = np.repeat(c, 3) if c.ndim == 0 else c
    if c.shape != (3,) or np.any(c <= 0) or np.any(c > 1) or not distance > 0:
        raise ValueError(f"need 0 < color <= 1 (RGB) and distance > 0, got {color!r}, {distance!r}")
    return -np.log(c) / float(distance)


def beer_lambert(sigma_a, dist):
    """Transmittance ``exp(-sigma_a * d)`` (N, 3) for coefficients (N, 3) and lengths (N,) (``inf`` ok).

    Zero coefficients give 1 even for infinite lengths (no ``0 * inf``).
    """
    sigma_a = np.asarray(sigma_a, dtype=np.float64)
    d = np.broadcast_to(np.asarray(dist, dtype=np.float64)[:, None], sigma_a.shape)
    sd = np.multiply(sigma_a, d, out=np.zeros(sigma_a.shape), where=sigma_a > 0)
    return np.exp(-sd)


def _participates(m):
    """A dielectric with a constant index that bounds a volume takes part in the interface stacks
    (Material.is_dielectric, .ior; not Material.thin_walled)."""
    return (bool(m.is_dielectric) and not m.thin_walled and isinstance(m.ior, (int, float))
            and not isinstance(m.ior, bool))


class NestedMedia:
    """Per-scene tables of the dielectric media and the interface-stack operations.

    Parameters
    ----------
    materials : list of Material
        The scene's materials (index = material id).
    """

    def __init__(self, materials):
        n = len(materials)
        self.participates = np.array([_participates(m) for m in materials], dtype=bool)
        self.ior = np.ones(n)
        self.sigma_a = np.zeros((n, 3))
        prio = np.zeros(n)
        for k, m in enumerate(materials):
            if self.participates[k]:
                self.ior[k] = float(m.ior)
                prio[k] = float(m.priority)
                sa = m.absorption
                self.sigma_a[k] = np.broadcast_to(np.asarray(sa, dtype=np.float64), (3,))
        # dense integer ranks of the priorities (ties stay ties)
        _, self.rank = np.unique(prio, return_inverse=True)
        self.rank = self.rank.astype(np.int64)
        self.absorbing = bool(np.any(self.sigma_a > 0))

    @classmethod
    def for_scene(cls, materials):
        """The tables, or ``None`` when the scene needs no stack (<= 1 participating dielectric, none
        absorbing)."""
        media = cls(materials)
        if media.participates.sum() > 1 or media.absorbing:
            return media
        return None

    def describe(self, materials):
        """Which of ``materials`` bound volumes (nested media: more than one) and which absorb (Beer-Lambert, e.g.
        glTF KHR_materials_volume's attenuation), for a render's fallback reason."""
        labels = [m.label for m, p in zip(materials, self.participates) if p]
        absorbing = [m.label for m, p, s in zip(materials, self.participates, self.sigma_a) if p and np.any(s > 0)]
        parts = []
        if len(labels) > 1:
            parts.append(f"{len(labels)} volume dielectrics: {', '.join(labels)}")
        if absorbing:
            parts.append(f"absorbing: {', '.join(absorbing)}")
        return f"nested dielectrics or absorption ({'; '.join(parts)})"

    # -- stacks ---------------------------------------------------------------------------------
    @staticmethod
    def empty(n, capacity=2):
        """``n`` empty stacks (vacuum)."""
        return np.full((n, capacity), -1, dtype=np.int32)

    def top(self, stack):
        """Material id of the current medium per row (N,), -1 for vacuum."""
        n, k = stack.shape
        if k == 0:
            return np.full(n, -1, dtype=np.int32)
        valid = stack >= 0
        key = np.where(valid, self.rank[np.maximum(stack, 0)] * (k + 1) + np.arange(k)[None, :], -1)
        pos = np.argmax(key, axis=1)
        top = stack[np.arange(n), pos]
        return np.where(valid.any(axis=1), top, -1).astype(np.int32)

    @staticmethod
    def push(stack, m):
        """Stacks with ``m`` (N,) appended to each row (widened by one column if a row is full)."""
        count = (stack >= 0).sum(axis=1)
        if stack.shape[0] and count.max() >= stack.shape[1]:
            stack = np.concatenate([stack, np.full((stack.shape[0], 1), -1, dtype=stack.dtype)], axis=1)
        out = stack.copy()
        out[np.arange(stack.shape[0]), count] = m
        return out

    @staticmethod
    def remove(stack, m):
        """Stacks with the most recent entry equal to ``m`` (N,) removed from each row (no-op if absent)."""
        n, k = stack.shape
        if k == 0:
            return stack.copy()
        cols = np.arange(k)[None, :]
        match = stack == np.asarray(m)[:, None]
        j = np.where(match.any(axis=1), k - 1 - np.argmax(match[:, ::-1], axis=1), k)
        src = np.where(cols >= j[:, None], cols + 1, cols)
        padded = np.concatenate([stack, np.full((n, 1), -1, dtype=stack.dtype)], axis=1)
        return np.take_along_axis(padded, src, axis=1)

    def cross(self, stack, m, front):
        """Stacks after crossing the interface of material ``m`` (push when entering, remove when leaving)."""
        out = stack.copy()
        e = np.flatnonzero(front)
        x = np.flatnonzero(~front)
        if e.size:
            pushed = self.push(stack[e], m[e])
            if pushed.shape[1] > out.shape[1]:
                out = np.concatenate([out, np.full((out.shape[0], 1), -1, dtype=out.dtype)], axis=1)
            out[e] = pushed
        if x.size:
            out[x, :stack.shape[1]] = self.remove(stack[x], m[x])
        return out

    def classify(self, stack, m, front):
        """True/false hits and relative indices at hits on participating material ids ``m`` (N,).

        Returns
        -------
        true_hit : (N,) bool
        eta : (N,) float64
            ``eta_t / eta_i`` for a ray arriving on the side of ``wo`` (meaningful for true hits).
        """
        cur = self.top(stack)
        n_cur = np.where(cur >= 0, self.ior[np.maximum(cur, 0)], 1.0)
        after = self.top(self.remove(stack, m))
        n_after = np.where(after >= 0, self.ior[np.maximum(after, 0)], 1.0)
        inside = (stack == m[:, None]).any(axis=1)
        r_cur = np.where(cur >= 0, self.rank[np.maximum(cur, 0)], -1)
        enter_true = (cur < 0) | (self.rank[m] >= r_cur)
        leave_true = ~inside | (cur == m)
        true_hit = np.where(front, enter_true, leave_true)
        n_m = self.ior[m]
        eta = np.where(front, n_m / n_cur, np.where(inside, n_after, n_cur) / n_m)
        return true_hit, eta

    def eta_for_hits(self, stack, mids, front):
        """``eta_t / eta_i`` (N,) at true hits on participating materials (NaN at other hits)."""
        eta = np.full(mids.shape[0], np.nan)
        pi = np.flatnonzero(self.participates[mids])
        if pi.size:
            _, eta[pi] = self.classify(stack[pi], mids[pi], front[pi])
        return eta

    def spawn_stacks(self, stack, mids, front, src, refracted):
        """Stacks of spawned rays: row ``src`` of the hits' stacks, crossed where the ray refracted
        through a participating material (reflections keep the stack)."""
        out = stack[src]
        x = np.flatnonzero(refracted & self.participates[mids[src]])
        if x.size:
            crossed = self.cross(out[x], mids[src[x]], front[src[x]])
            if crossed.shape[1] > out.shape[1]:
                out = np.concatenate([out, np.full((out.shape[0], crossed.shape[1] - out.shape[1]), -1,
                                                   dtype=out.dtype)], axis=1)
            out[x] = crossed
        return out

    def attenuation(self, stack, dist):
        """Beer-Lambert transmittance (N, 3) over lengths ``dist`` (N,) in each row's current medium.

        ``dist`` may be ``inf`` (a miss: 0 inside an absorbing medium, 1 elsewhere) or NaN (a ray
        :meth:`skip_false_hits` dropped: 0).
        """
        cur = self.top(stack)
        sig = np.where((cur >= 0)[:, None], self.sigma_a[np.maximum(cur, 0)], 0.0)
        dropped = np.isnan(dist)
        return np.where(dropped[:, None], 0.0, beer_lambert(sig, np.where(dropped, 0.0, dist)))

    # -- false hits ----------------------------------------------------------------------------
    def hit_material_front(self, geo, hits, d):
        """Material id and front flag (ray on the outward side) of hits, from the geometry table
        (the same float64 winding normal as :func:`pyrt.geometry.surface_from_hits`)."""
        face = geo.face_offset[hits.mesh_id] + hits.prim_id
        tri = geo.faces[face]
        v0, v1, v2 = geo.vertices[tri[:, 0]], geo.vertices[tri[:, 1]], geo.vertices[tri[:, 2]]
        ng_out = np.cross(v1 - v0, v2 - v0)
        front = np.einsum("ij,ij->i", ng_out, -d) >= 0
        return geo.face_material[face], front

    def skip_false_hits(self, geo, hits, o, d, stack, intersect, respawn):
        """Continue rays through false hits until each ray's closest hit is a true one (or a miss).

        Parameters
        ----------
        geo : pyrt.geometry.GeometryTable
        hits : pyrt.geometry.accel.Hits
            Closest hits of the rays ``o, d`` (unit directions).
        stack : (N, K) int32
        intersect : callable
            ``intersect(o, d) -> Hits`` (the integrator's, for its statistics).
        respawn : callable
            ``respawn(hit_subset, o_subset, d_subset) -> origins`` just past the hits on the far side
            (the integrator's offset strategy on a surface batch).

        Returns
        -------
        hits, t_total, stack
            Hits with false hits replaced by what lies behind them (their ``t`` measured from ``o``);
            ``t_total`` (N,) the distance from ``o`` to the final hit (``inf`` for misses); the
            updated stacks. Rays that needed more than :data:`MAX_FALSE_HITS` continuations become
            misses with ``t_total = nan`` (:meth:`attenuation` gives them zero weight).
        """

        n = o.shape[0]
        t_acc = np.zeros(n)
        fields = ("hit", "t", "mesh_id", "prim_id", "u", "v", "ng")
        cur = {f: np.array(getattr(hits, f), copy=True) for f in fields}
        todo = np.arange(n)
        oo = o
        for _ in range(MAX_FALSE_HITS):
            hit = cur["hit"][todo]
            idx = todo[hit]
            if idx.size == 0:
                break
            sub = Hits(**{f: cur[f][idx] for f in fields})
            mat, front = self.hit_material_front(geo, sub, d[idx])
            part = self.participates[mat]
            false = np.zeros(idx.size, dtype=bool)
            if np.any(part):
                pi = np.flatnonzero(part)
                true_hit, _ = self.classify(stack[idx[pi]], mat[pi], front[pi])
                false[pi] = ~true_hit
            if not np.any(false):
                todo = idx[:0]
                break
            f_idx = idx[false]
            t_acc[f_idx] += cur["t"][f_idx]
            stack_f = self.cross(stack[f_idx], mat[false], front[false])
            if stack_f.shape[1] > stack.shape[1]:
                stack = np.concatenate([stack, np.full((n, stack_f.shape[1] - stack.shape[1]), -1,
                                                       dtype=stack.dtype)], axis=1)
            stack[f_idx] = stack_f
            fsub = Hits(**{f: cur[f][f_idx] for f in fields})
            new_o = respawn(fsub, oo[f_idx], d[f_idx])
            oo = oo.copy() if oo is o else oo
            oo[f_idx] = new_o
            nh = intersect(new_o, d[f_idx])
            for f in fields:
                cur[f][f_idx] = getattr(nh, f)
            todo = f_idx
        else:
            still = todo[cur["hit"][todo]]
            if still.size:
                cur["hit"][still] = False
                t_acc[still] = np.nan
        t_total = np.where(cur["hit"], t_acc + np.where(cur["hit"], cur["t"], 0.0), np.inf)
        cur["t"] = np.where(cur["hit"], t_total, cur["t"])    # depth AOV: distance from the original origin
        t_total[np.isnan(t_acc)] = np.nan
        return Hits(**cur), t_total, stack
