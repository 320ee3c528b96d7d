"""The ground truth: exact shapes (spheres, boxes), the light as the truth sees it, and the tracer that
labels a camera ray LIT, SHADOW, UNSURE (the don't-care band) or BACKGROUND (see :mod:`pyrt.apps.acne`)."""
from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

LIT, SHADOW, UNSURE, BACKGROUND = 1, 0, -1, -2


# ================================================================================ exact shapes
def _ulp32(x):
    return float(np.spacing(np.float32(abs(x))))


def _perp_frame(v):
    a = np.where(np.abs(v[:, 0:1]) > 0.9, np.array([[0.0, 1.0, 0.0]]), np.array([[1.0, 0.0, 0.0]]))
    e1 = np.cross(v, a)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(v, e1)


def _dot(a, b):
    return np.einsum("ij,ij->i", a, b)


@dataclass
class Sphere:
    """Exact sphere; its mesh lies between the balls of radius ``r_in`` and ``r`` (up to ``tol``)."""

    center: np.ndarray
    r: float
    r_in: float
    tol: float
    normal_tol: float
    material: str = "diffuse"
    dir_tol: float = 0.0

    def _radius(self, grow):
        return self.r + self.tol if grow > 0 else max(self.r_in - self.tol, 0.0)

    def interval(self, o, d, grow):
        """Entry/exit parameters and outward normals of the grown (+1) or shrunk (-1) ball."""
        R = self._radius(grow)
        oc = o - self.center
        b = _dot(oc, d)
        c = _dot(oc, oc) - R * R
        disc = b * b - c
        hit = (disc >= 0) & (R > 0)
        sq = np.sqrt(np.maximum(disc, 0.0))
        t0 = np.where(hit, -b - sq, np.inf)
        t1 = np.where(hit, -b + sq, -np.inf)
        with np.errstate(invalid="ignore"):
            n0 = (o + np.where(hit, t0, 0)[:, None] * d - self.center) / max(R, 1e-300)
            n1 = (o + np.where(hit, t1, 0)[:, None] * d - self.center) / max(R, 1e-300)
        return t0, t1, n0, n1


@dataclass
class Box:
    """Exact axis-aligned box ``[lo, hi]`` (a rectangle when one extent is 0)."""

    lo: np.ndarray
    hi: np.ndarray
    tol: float
    normal_tol: float
    material: str = "diffuse"
    dir_tol: float = 0.0

    def bounds(self, grow):
        if grow > 0:
            return self.lo - self.tol, self.hi + self.tol
        lo, hi = self.lo + self.tol, self.hi - self.tol
        mid = 0.5 * (self.lo + self.hi)
        thin = lo > hi                       # thinner than 2 tol: the mid-plane is surely inside the mesh
        return np.where(thin, mid, lo), np.where(thin, mid, hi)

    def interval(self, o, d, grow):
        lo, hi = self.bounds(grow)
        par = d == 0
        inside = (o >= lo) & (o <= hi)
        ds = np.where(par, 1.0, d)
        ta = np.where(par, np.where(inside, -np.inf, np.inf), (lo - o) / ds)
        tb = np.where(par, np.inf, (hi - o) / ds)
        tmin, tmax = np.minimum(ta, tb), np.maximum(ta, tb)
        k0, k1 = np.argmax(tmin, axis=1), np.argmin(tmax, axis=1)
        t0, t1 = tmin.max(axis=1), tmax.min(axis=1)
        hit = t0 <= t1
        rows = np.arange(o.shape[0])
        n0 = np.zeros_like(o)
        n1 = np.zeros_like(o)
        n0[rows, k0] = -np.sign(d[rows, k0])
        n1[rows, k1] = np.sign(d[rows, k1])
        return np.where(hit, t0, np.inf), np.where(hit, t1, -np.inf), n0, n1


# ================================================================================ lights (truth side)
@dataclass
class LightTruth:
    kind: str
    position: np.ndarray = None     # point / spot
    direction: np.ndarray = None    # directional: travel direction
    axis: np.ndarray = None         # spot
    cos_outer: float = -1.0
    radius: float = 0.0             # ball radius for shadow segments
    tol: float = 0.0                # positional tolerance of shading points (for the cone edge)

    def toward(self, q):
        """``wi, dist`` from points ``q`` (N, 3)."""
        if self.kind == "directional":
            return np.broadcast_to(-self.direction, q.shape).copy(), np.full(q.shape[0], np.inf)
        v = self.position - q
        dist = np.linalg.norm(v, axis=1)
        return v / np.maximum(dist, 1e-300)[:, None], dist

    def cone(self, q, wi, dist):
        """(surely inside, surely outside) the spot cone."""
        n = q.shape[0]
        if self.kind != "spot":
            return np.ones(n, bool), np.zeros(n, bool)
        c = -(wi @ self.axis)
        band = math.sin(math.acos(max(-1.0, min(1.0, self.cos_outer)))) * (2 * self.tol / np.maximum(dist, 1e-300)) \
            + 1e-9
        return c > self.cos_outer + band, c < self.cos_outer - band


# ================================================================================ truth tracer
def _reflect(d, n):
    return d - 2 * _dot(d, n)[:, None] * n


def _refract(d, n, eta):
    """Refract unit ``d`` at unit ``n`` facing against ``d``; ``eta = n_i / n_t``. Returns (t, tir)."""
    cos_i = -_dot(d, n)
    sin2 = eta * eta * np.maximum(0.0, 1 - cos_i * cos_i)
    tir = sin2 > 1
    cos_t = np.sqrt(np.maximum(0.0, 1 - sin2))
    t = eta * d + (eta * cos_i - cos_t)[:, None] * n
    return t / np.linalg.norm(t, axis=1, keepdims=True), tir


def _combine(labels):
    out = labels[0].copy()
    for b in labels[1:]:
        out = np.where(out == b, out, UNSURE)
    return out


@dataclass
class Truth:
    """Exact scene for the ground truth: shapes (their materials), light, glass index of refraction."""

    shapes: list
    light: LightTruth
    ior: float = 1.5

    def _first_hit(self, o, d, exclude=-1):
        """Which shape the mesh ray surely hits first: (k or -1 if unsure, background mask, T_out, T_in, N)."""
        n = o.shape[0]
        K = len(self.shapes)
        t_out = np.full((K, n), np.inf)
        t_in = np.full((K, n), np.inf)
        n_out = np.zeros((K, n, 3))
        n_in = np.zeros((K, n, 3))
        inside = np.zeros(n, bool)
        for k, sh in enumerate(self.shapes):
            if k == exclude:
                continue
            a0, a1, an, _ = sh.interval(o, d, +1)
            b0, b1, bn, _ = sh.interval(o, d, -1)
            inside |= (a0 < 0) & (a1 > 0)
            t_out[k] = np.where(a0 > 0, a0, np.inf)
            t_in[k] = np.where(b0 > 0, b0, np.inf)
            n_out[k], n_in[k] = an, bn
        k_in = np.argmin(t_in, axis=0)
        tin = t_in[k_in, np.arange(n)]
        masked = t_out.copy()
        masked[k_in, np.arange(n)] = np.inf
        other = masked.min(axis=0)
        sure = np.isfinite(tin) & (tin < other) & ~inside
        background = np.all(~np.isfinite(t_out), axis=0) & ~inside
        return np.where(sure, k_in, -1), background, t_out, t_in, n_out, n_in

    def _point_label(self, q, nrm, k):
        sh = self.shapes[k]
        lt = self.light
        wi, dist = lt.toward(q)
        cos = _dot(nrm, wi)
        sn = math.sin(sh.normal_tol)
        facing, back = cos > sn, cos < -sn
        c_in, c_out = lt.cone(q, wi, dist)
        tseg = dist - lt.radius
        maybe = np.zeros(q.shape[0], bool)
        sure = np.zeros(q.shape[0], bool)
        for j, oc in enumerate(self.shapes):
            if j == k:
                continue      # every shape is convex: its own shadow is the n . wi test
            a0, a1, _, _ = oc.interval(q, wi, +1)
            b0, b1, _, _ = oc.interval(q, wi, -1)
            near = (a0 <= 0) & (a1 >= 0)           # q within tol of the occluder: a contact
            maybe |= (a0 < tseg) & (a1 > 0) | near
            sure |= (b0 <= tseg) & (b1 >= 0) & ~near
        lit = facing & c_in & ~maybe
        shadow = back | c_out | sure
        return np.where(lit, LIT, np.where(shadow, SHADOW, UNSURE))

    def _perturbed(self, r, angle):
        if angle <= 0:
            return [r]
        e1, e2 = _perp_frame(r)
        s = math.tan(angle)
        out = [r]
        for e in (e1, -e1, e2, -e2):
            v = r + s * e
            out.append(v / np.linalg.norm(v, axis=1, keepdims=True))
        return out

    def trace(self, o, d, depth=0, exclude=-1):
        """Ground-truth label per ray (LIT, SHADOW, UNSURE or BACKGROUND)."""
        n = o.shape[0]
        out = np.full(n, UNSURE, dtype=np.int8)
        if n == 0:
            return out
        k, background, t_out, t_in, n_out, n_in = self._first_hit(o, d, exclude)
        out[background] = BACKGROUND
        for ki, sh in enumerate(self.shapes):
            idx = np.flatnonzero(k == ki)
            if idx.size == 0:
                continue
            o_, d_ = o[idx], d[idx]
            ta, tb = t_out[ki, idx], t_in[ki, idx]
            na, nb = n_out[ki, idx], n_in[ki, idx]
            if sh.material == "diffuse":
                labels = []
                for t, nn in ((ta, na), (0.5 * (ta + tb), na), (tb, nb)):
                    q = o_ + t[:, None] * d_
                    if isinstance(sh, Sphere):
                        nn = (q - sh.center) / np.linalg.norm(q - sh.center, axis=1, keepdims=True)
                    labels.append(self._point_label(q, nn, ki))
                out[idx] = _combine(labels)
            elif depth >= 1:
                out[idx] = UNSURE
            elif sh.material == "mirror":
                labels = []
                for t, nn in ((ta, na), (tb, nb)):
                    q = o_ + t[:, None] * d_
                    r = _reflect(d_, nn)
                    for rr in self._perturbed(r, sh.dir_tol):
                        labels.append(self.trace(q, rr, depth + 1, exclude=ki))
                out[idx] = _combine(labels)
            else:  # glass: the Fresnel reflection must see nothing; the refracted path through the box
                labels = []
                for grow, t, nn in ((+1, ta, na), (-1, tb, nb)):
                    q = o_ + t[:, None] * d_
                    refl = self.trace(q, _reflect(d_, nn), depth + 1, exclude=ki)
                    ti, tir0 = _refract(d_, nn, 1.0 / self.ior)
                    _, e1, _, ne = sh.interval(q - ti * 1e-9 * max(1.0, float(np.abs(q).max())), ti, grow)
                    qe = q + np.where(np.isfinite(e1), e1, 0)[:, None] * ti
                    to, tir1 = _refract(ti, -ne, self.ior)
                    bad = tir0 | tir1 | ~np.isfinite(e1) | (refl != BACKGROUND)
                    for rr in self._perturbed(to, sh.dir_tol):
                        lab = self.trace(qe, rr, depth + 1, exclude=ki)
                        labels.append(np.where(bad, UNSURE, lab))
                out[idx] = _combine(labels)
        return out
