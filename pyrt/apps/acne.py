"""The shadow-acne suite: offset strategies against stress scenes with analytic ground truth.

Every case is a small scene built from exact shapes -- spheres, boxes and rectangles (boxes of zero
thickness) -- tessellated for the renderer, plus one light. The ground truth is computed from the
*exact* shapes, not from the mesh, for exactly the float32 camera rays Embree traces (pixel centres):
for each pixel, which shape the ray hits and whether that point sees the light. Comparing with the
rendered image (a pixel is "lit" iff its radiance is > 0: black background, no ambient light) gives

- **acne**: pixels dark where the truth says lit (self-intersection, terminator, a light hidden by the
  surface it is mounted on, a specular ray re-hitting its own surface);
- **leak**: pixels lit where the truth says shadow (an origin pushed past a thin occluder, a detached
  contact shadow);
- **cost**: wall-clock time per shadow ray (computing the origins and tmax plus Embree's occlusion test).

Don't-care band (stated, not tuned)
-----------------------------------
A pixel is "don't care" when its label could change within the tolerances of the mesh that represents
the exact shape. Every shape has a positional tolerance ``tol`` = one float32 ulp of its largest world
coordinate (vertices are rounded to float32: at most 0.87 ulp) and spheres additionally lie between
their tessellation's in-ball (radius ``r_in``, the smallest face-plane distance) and the exact ball.
The truth is evaluated for the shape *grown* by ``tol`` and *shrunk* by ``tol`` (and to ``r_in``),
at the camera ray's entry points into both (and half way): a pixel counts only if all agree. So the
band is where
- the camera ray's first hit is ambiguous between the grown and shrunk shapes (silhouettes);
- the shadow ray passes between a grown and a shrunk occluder (shadow boundaries: width ``tol``
  plus, for spheres, the tessellation gap ``r - r_in``, measured on the occluder);
- ``|n . wi| < sin(normal_tol)`` (the shape's own terminator): for box faces the tilt float32
  rounding can give a face, for smooth spheres the largest angle between the mesh's vertex normals
  and the exact radial direction plus that rounding tilt, for flat-shaded spheres the largest angle
  between a face normal and the radial directions over that face (the facets *are* the surface there);
- the shadow point is within ``tol`` of another shape (contacts), or the last ``LIGHT_RADIUS`` of the
  shadow segment (the light is a ball of radius 1e-3 of the scene size: a light mounted on a wall);
- a spot's cone edge within the angle ``2 tol / distance``;
- mirror and glass: all of the above after the bounce, for the reflected/refracted ray and for that
  ray tilted by the angle float32 rounding can give the mirror's or glass's faces.
The fraction of don't-care pixels is reported per case (a few percent; the point is that it is thin).

Running it on your own offset function
--------------------------------------
``run_matrix(offset=my_fn)`` with ``my_fn(surf, w) -> origins`` ((N, 3) float64; ``surf`` a
:class:`pyrt.geometry.SurfaceBatch`: ``p``, ``ng`` (facing the viewer), ``p_error``, ``bary``,
``tri_v``, ``tri_n``...), or ``python -m pyrt.apps.acne --offset mymodule:my_fn``. A plain function gets
pbrt's shadow ``tmax = (1 - 1e-4) t``; wrap it in :class:`pyrt.geometry.offsets.Strategy` to choose.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import argparse
import importlib
import math
import sys
import threading
import time

import numpy as np
import trimesh

from pyrt.geometry import offsets
from pyrt.core.camera import Camera
from pyrt.integrators import PreparedScene
from pyrt.render import render_full
from pyrt.lights.punctual import DirectionalLight, PointLight, SpotLight
from pyrt.materials import Glass, Lambert, Mirror
from pyrt.scene import Scene

LIT, SHADOW, UNSURE, BACKGROUND = 1, 0, -1, -2

#: Side of the floor in scene units (the "scene size" that scale and thicknesses refer to).
SCENE_SIZE = 4.0
#: Thin walls and panels are this fraction of the scene size thick.
THIN = 1e-4
#: The light is a ball of this radius (fraction of the scene size) for the truth's shadow segments.
LIGHT_RADIUS = 1e-3
#: Distance of point and spot lights from the scene centre (scene units).
LIGHT_DISTANCE = 6.0

GEOMETRIES = ("plane", "sphere_fine", "sphere_lowpoly", "sphere_flat", "thin_wall", "contact", "corner",
              "mirror", "glass", "wall_lamp")
LIGHTS = ("directional", "point", "spot")


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


# ================================================================================ cases
@dataclass(frozen=True)
class Case:
    """One scene of the matrix: geometry, light type, scale, translation, light incidence (degrees)."""

    geometry: str
    light: str = "directional"
    scale: float = 1.0
    translation: float = 0.0
    incidence: float = 45.0

    def __post_init__(self):
        if self.geometry not in GEOMETRIES:
            raise ValueError(f"Case: unknown geometry {self.geometry!r}; choose from {GEOMETRIES}")
        if self.light not in LIGHTS:
            raise ValueError(f"Case: unknown light {self.light!r}; choose from {LIGHTS}")
        if not (self.scale > 0 and math.isfinite(self.scale)):
            raise ValueError(f"Case: scale must be > 0, got {self.scale!r}")
        if not 0 <= self.incidence < 90:
            raise ValueError(f"Case: incidence must be in [0, 90) degrees, got {self.incidence!r}")
        if self.geometry == "wall_lamp" and self.light == "directional":
            raise ValueError("Case: wall_lamp needs a point or spot light (the light is mounted on the wall)")

    @property
    def id(self):
        return (f"{self.geometry}-{self.light}-s{self.scale:g}-t{self.translation:g}-i{self.incidence:g}")


def default_matrix():
    """The matrix: every geometry x light at the base (scale 1, at the origin, 45 deg), then sweeps.

    Sweeps (directional light; wall_lamp: point light): scale 1e-4, 1e-2, 1e2, 1e4; translation
    (t, t, t) for t = 1e2, 1e4, 1e5 at scale 1 and t = 1e6 at scale 1e2 (at scale 1 float32 cannot hold
    a 1-unit sphere 1e6 from the origin: its ulp, 0.06, is 12 % of the radius); incidence 0, 70, 85,
    89.9 deg; grazing 89.9 deg with a point light; and the combinations 89.9 deg at t = 1e4 (the floor
    at y = 0 is the easy case: floats near 0 are dense), scale 1e-4 at t = 1 (a millimetre part one unit
    from the origin) and scale 1e4 at t = 1e6.
    """
    cases = []
    for g in GEOMETRIES:
        for lt in LIGHTS:
            if g == "wall_lamp" and lt == "directional":
                continue
            cases.append(Case(g, lt))
    for g in GEOMETRIES:
        lt = "point" if g == "wall_lamp" else "directional"
        for s in (1e-4, 1e-2, 1e2, 1e4):
            cases.append(Case(g, lt, scale=s))
        for t in (1e2, 1e4, 1e5):
            if g == "wall_lamp" and t == 1e5:
                continue   # float32 places the wall to 0.008: more than the lamp's radius, nothing is decidable
            cases.append(Case(g, lt, translation=t))
        cases.append(Case(g, lt, scale=1e2, translation=1e6))
        if g != "wall_lamp":
            for inc in (0.0, 70.0, 85.0, 89.9):
                cases.append(Case(g, lt, incidence=inc))
            cases.append(Case(g, "point", incidence=89.9))
        # combined extremes: grazing light off the origin, a millimetre scene 1 unit from the origin, a
        # large scene far away
        if g != "wall_lamp":
            cases.append(Case(g, lt, translation=1e4, incidence=89.9))
        cases.append(Case(g, lt, scale=1e-4, translation=1.0))
        cases.append(Case(g, lt, scale=1e4, translation=1e6))
    return cases


def quick_matrix():
    """A subset for the default test run: the base cases and the extreme of every sweep."""
    keep = []
    for c in default_matrix():
        base = c.scale == 1 and c.translation == 0 and c.incidence == 45
        extreme = (c.scale in (1e-4, 1e4) or c.translation in (1e5, 1e6) or c.incidence == 89.9) and \
            c.light == ("point" if c.geometry == "wall_lamp" else "directional")
        if base or extreme:
            keep.append(c)
    return keep


def _icosphere_bounds(subdiv, smooth):
    """In-ball radius (unit sphere) and the normal tolerance (rad) of a trimesh icosphere."""
    m = trimesh.creation.icosphere(subdivisions=subdiv, radius=1.0)
    centres = m.triangles_center
    r_in = float(np.abs((centres * m.face_normals).sum(1)).min())
    v = m.vertices / np.linalg.norm(m.vertices, axis=1, keepdims=True)
    if smooth:
        vn = m.vertex_normals
        ang = float(np.arccos(np.clip((vn * v).sum(1), -1, 1)).max())
    else:
        tri = v[m.faces]                                              # (F, 3, 3) radial dirs at corners
        ang = float(np.arccos(np.clip(np.einsum("fk,fjk->fj", m.face_normals, tri), -1, 1)).max())
    edge = float(m.edges_unique_length.min())
    return r_in, ang, edge


_GEOM = {
    # name: (shapes in scene units, light azimuth (x, z) of the direction toward the light, camera)
    # shape: ("box", lo, hi, material) | ("sphere", centre, r, subdiv, smooth, material)
    "plane": ([], (1.0, -1.0)),
    "sphere_fine": ([("sphere", (0, 0.9, 0), 0.5, 4, True, "diffuse")], (1.0, 0.25)),
    "sphere_lowpoly": ([("sphere", (0, 0.9, 0), 0.5, 1, True, "diffuse")], (1.0, 0.25)),
    "sphere_flat": ([("sphere", (0, 0.9, 0), 0.5, 2, False, "diffuse")], (1.0, 0.25)),
    "thin_wall": ([("box", (-0.8, 0.25, -0.8), (0.8, 0.25 + THIN * SCENE_SIZE, 0.8), "diffuse")], (0.3, -0.95)),
    "contact": ([("sphere", (-0.7, 0.5, 0.0), 0.5, 3, True, "diffuse"),
                 ("box", (0.35, 0.0, -0.35), (1.05, 0.7, 0.35), "diffuse")], (0.8, -0.6)),
    "corner": ([("box", (-2.0, 0.0, -0.3 - THIN * SCENE_SIZE), (2.0, 1.2, -0.3), "diffuse")], (0.35, -0.94)),
    "mirror": ([("box", (-1.6, 0.0, -1.3), (1.6, 1.6, -1.2), "mirror"),
                ("sphere", (0.35, 0.6, 0.1), 0.35, 3, True, "diffuse")], (0.5, 0.866)),
    "glass": ([("box", (-1.0, 0.5, -1.0), (1.0, 0.6, 1.0), "glass"),
               ("box", (-0.2, 0.0, -0.2), (0.2, 0.3, 0.2), "diffuse")], (1.0, 0.0)),
    "wall_lamp": ([("box", (-2.0, 0.0, -1.5), (2.0, 2.0, -1.2), "diffuse"),
                   ("sphere", (0.4, 0.45, -0.4), 0.3, 3, True, "diffuse")], None),
}
_CAMERA = {"default": ((0.0, 2.6, 4.2), (0.0, 0.2, 0.0)), "mirror": ((0.0, 1.4, 3.6), (0.0, 0.5, -1.0)),
           "glass": ((0.0, 3.2, 1.6), (0.0, 0.0, 0.0))}
_LAMP = (0.0, 1.0, -1.2)          # on the wall's front face z = -1.2
_LAMP_TARGET = (0.0, 0.0, 0.6)


@dataclass
class BuiltCase:
    case: Case
    scene: Scene
    truth: Truth
    max_depth: int


def build_case(case, width=64, height=48):
    """Scene (for pyrt) and exact truth (for the labels) of ``case``; world = scale * local + translation."""
    s, T = float(case.scale), float(case.translation)
    shift = np.full(3, T)

    def W(p):
        return s * np.asarray(p, dtype=np.float64) + shift

    cam_key = case.geometry if case.geometry in _CAMERA else "default"
    cp, ct = _CAMERA[cam_key]
    cam = Camera(position=W(cp), target=W(ct), fov=42.0, width=width, height=height, spp=1, jitter=False)
    scene = Scene(cam)
    xf = np.diag([s, s, s, 1.0])
    xf[:3, 3] = shift
    mats = {"diffuse": Lambert(albedo=0.8), "mirror": Mirror(reflectance=1.0), "glass": Glass(ior=1.5)}

    def tol_of(vertices_world):
        return _ulp32(np.max(np.abs(vertices_world))) + 1e-12 * s

    shapes = []
    # the floor: a 2-triangle rectangle at y = 0
    h = SCENE_SIZE / 2
    fv = np.array([[-h, 0, h], [h, 0, h], [h, 0, -h], [-h, 0, -h]])
    scene.add_mesh((fv, np.array([[0, 1, 2], [0, 2, 3]])), mats["diffuse"], transform=xf, smooth=False, name="floor")
    ftol = tol_of(W(fv))
    shapes.append(Box(W((-h, 0, -h)), W((h, 0, h)), ftol, normal_tol=2 * ftol / (s * SCENE_SIZE)))
    spec, az = _GEOM[case.geometry]
    for i, sp in enumerate(spec):
        if sp[0] == "box":
            _, lo, hi, mat = sp
            lo, hi = np.asarray(lo, float), np.asarray(hi, float)
            m = trimesh.creation.box(bounds=np.stack([lo, hi]))
            scene.add_mesh(m, mats[mat], transform=xf, smooth=False, name=f"box{i}")
            tol = tol_of(W(m.vertices))
            ext = np.sort(hi - lo)
            face_min = max(ext[1], 1e-300) * s       # the smaller side of the largest faces
            tilt = math.atan(2 * tol / face_min)
            shapes.append(Box(W(lo), W(hi), tol, normal_tol=tilt, material=mat, dir_tol=2 * tilt + 1e-9))
        else:
            _, c, r, sub, smooth, mat = sp
            m = trimesh.creation.icosphere(subdivisions=sub, radius=r)
            m.apply_translation(c)
            scene.add_mesh(m, mats[mat], transform=xf, smooth=smooth, name=f"sphere{i}")
            tol = tol_of(W(m.vertices))
            r_in, ang, edge = _icosphere_bounds(sub, smooth)
            tilt = math.atan(2 * tol / (edge * r * s))
            shapes.append(Sphere(W(c), r * s, r_in * r * s, tol, normal_tol=ang + tilt + 1e-9, material=mat,
                                 dir_tol=2 * (ang + tilt)))
    pos_tol = max(sh.tol for sh in shapes)
    # the light
    theta = math.radians(case.incidence)
    if case.geometry == "wall_lamp":
        lp = W(_LAMP)
        axis = W(_LAMP_TARGET) - lp
        axis /= np.linalg.norm(axis)
        dist_c = s * float(np.linalg.norm(np.subtract(_LAMP_TARGET, _LAMP)))
    else:
        ax, az_ = az
        nz = math.hypot(ax, az_)
        omega = np.array([math.sin(theta) * ax / nz, math.cos(theta), math.sin(theta) * az_ / nz])
        lp = shift + s * LIGHT_DISTANCE * omega
        axis = -omega
        dist_c = s * LIGHT_DISTANCE
    radius = LIGHT_RADIUS * SCENE_SIZE * s
    I = dist_c ** 2
    if case.light == "directional":
        light = DirectionalLight(axis, irradiance=1.0)
        lt = LightTruth("directional", direction=axis.copy(), tol=pos_tol)
    elif case.light == "point":
        light = PointLight(lp, intensity=I)
        lt = LightTruth("point", position=lp, radius=radius, tol=pos_tol)
    else:
        outer, inner = (70.0, 60.0) if case.geometry == "wall_lamp" else (55.0, 45.0)
        light = SpotLight(lp, axis, intensity=I, inner_angle=inner, outer_angle=outer)
        lt = LightTruth("spot", position=lp, axis=axis, cos_outer=math.cos(math.radians(outer)), radius=radius,
                        tol=pos_tol)
    scene.add_light(light)
    max_depth = 2 if case.geometry == "glass" else 1
    return BuiltCase(case, scene, Truth(shapes, lt), max_depth)


def camera_rays32(cam):
    """The camera's pixel-centre rays as Embree sees them (float32), in float64, row-major."""
    n = cam.width * cam.height
    rays = cam.generate_rays(0, n, np.random.default_rng(0))
    o, d = rays.origins, rays.directions
    o32 = np.ascontiguousarray(o, dtype=np.float32).astype(np.float64)
    d32 = np.ascontiguousarray(d, dtype=np.float32).astype(np.float64)
    return o32, d32 / np.linalg.norm(d32, axis=1, keepdims=True)


def truth_labels(built):
    """(H, W) int8 ground-truth labels of a built case."""
    cam = built.scene.camera
    o, d = camera_rays32(cam)
    return built.truth.trace(o, d).reshape(cam.height, cam.width)


# ================================================================================ running
@dataclass(frozen=True)
class _Timed(offsets.Strategy):
    """A strategy that accumulates the wall-clock time of its shadow-ray set-up."""

    inner: object = None
    clock: list = field(default_factory=lambda: [0.0])
    lock: object = field(default_factory=threading.Lock)   # chunks may run on several threads

    def __call__(self, surf, w):
        return self.inner(surf, w)

    def shadow(self, surf, wi, dist, end=None):
        t0 = time.perf_counter()
        r = self.inner.shadow(surf, wi, dist, end)
        dt = time.perf_counter() - t0
        with self.lock:
            self.clock[0] += dt
        return r


@dataclass
class CaseResult:
    """Outcome of one (case, strategy): pixel counts, timing, and the images for reports."""

    case: Case
    strategy: str
    acne: int
    leak: int
    n_lit: int
    n_shadow: int
    n_dontcare: int
    shadow_rays: int
    time_shadow: float          # seconds: origins + tmax + Embree occlusion test
    truth: np.ndarray = field(repr=False, default=None)
    lit: np.ndarray = field(repr=False, default=None)
    image: np.ndarray = field(repr=False, default=None)

    @property
    def ok(self):
        return self.acne == 0 and self.leak == 0

    @property
    def us_per_shadow_ray(self):
        return 1e6 * self.time_shadow / max(self.shadow_rays, 1)

    @property
    def error_rate(self):
        """(acne + leak) / labelled pixels."""
        return (self.acne + self.leak) / max(self.n_lit + self.n_shadow, 1)


def _strategy_name(offset):
    if isinstance(offset, str):
        return offset
    if offset is None:
        return offsets.DEFAULT
    return getattr(offset, "name", None) or getattr(offset, "__name__", "custom")


def run_case(case, offset=None, *, width=64, height=48, built=None, prepared=None, truth=None, threads=None):
    """Render ``case`` with ``offset`` (name, callable(surf, w) -> origins, or Strategy) and score it."""
    built = built if built is not None else build_case(case, width, height)
    truth = truth if truth is not None else truth_labels(built)
    strat = offsets.get_strategy(offset)
    timed = _Timed(name=strat.name, origin=strat.origin, tmax=strat.tmax, terminator=strat.terminator, inner=strat)
    res = render_full(built.scene, spp=1, max_depth=built.max_depth, offset=timed, progress=False,
                      prepared=prepared, threads=threads)
    lit = res.image.max(axis=2) > 0
    acne = int(np.sum((truth == LIT) & ~lit))
    leak = int(np.sum((truth == SHADOW) & lit))
    return CaseResult(case=case, strategy=_strategy_name(offset), acne=acne, leak=leak,
                      n_lit=int(np.sum(truth == LIT)), n_shadow=int(np.sum(truth == SHADOW)),
                      n_dontcare=int(np.sum(truth == UNSURE)), shadow_rays=res.stats.shadow_rays,
                      time_shadow=timed.clock[0] + res.stats.time_occluded, truth=truth, lit=lit, image=res.image)


def run_matrix(offset=None, cases=None, *, strategies=None, width=64, height=48, keep_images=False, threads=None,
               progress=False):
    """Run ``cases`` (default :func:`default_matrix`) for one ``offset`` or a list of ``strategies``.

    Returns a list of :class:`CaseResult` (case-major). Each case's scene and truth are built once.
    """
    cases = default_matrix() if cases is None else list(cases)
    strategies = [offset] if strategies is None else list(strategies)
    out = []
    for i, case in enumerate(cases):
        built = build_case(case, width, height)
        truth = truth_labels(built)
        ps = PreparedScene(built.scene, threads=threads)
        try:
            for st in strategies:
                r = run_case(case, st, built=built, prepared=ps, truth=truth)
                if not keep_images:
                    r.truth = r.lit = r.image = None
                out.append(r)
        finally:
            ps.close()
        if progress:
            print(f"\r[{i + 1}/{len(cases)}] {case.id}" + " " * 20, end="", file=sys.stderr, flush=True)
    if progress:
        print(file=sys.stderr)
    return out


def summarize(results):
    """Per strategy: cases, failing cases, acne, leak, labelled pixels, rate and mean us per shadow ray."""
    out = {}
    for r in results:
        s = out.setdefault(r.strategy, {"cases": 0, "failing": 0, "acne": 0, "leak": 0, "pixels": 0,
                                        "time": 0.0, "rays": 0})
        s["cases"] += 1
        s["failing"] += 0 if r.ok else 1
        s["acne"] += r.acne
        s["leak"] += r.leak
        s["pixels"] += r.n_lit + r.n_shadow
        s["time"] += r.time_shadow
        s["rays"] += r.shadow_rays
    for s in out.values():
        s["rate"] = (s["acne"] + s["leak"]) / max(s["pixels"], 1)
        s["us_per_ray"] = 1e6 * s["time"] / max(s["rays"], 1)
    return out


def format_table(results):
    """Text table: one row per case, ``acne/leak`` per strategy, then per-strategy totals and cost."""
    strategies = list(dict.fromkeys(r.strategy for r in results))
    cases = list(dict.fromkeys(r.case for r in results))
    by = {(r.case, r.strategy): r for r in results}
    w = max(9, *(len(s) for s in strategies))
    cw = max(len(c.id) for c in cases)
    lines = [f"{'case':<{cw}} {'care':>5} {'dc%':>5} " + " ".join(f"{s:>{w}}" for s in strategies)]
    for c in cases:
        r0 = by[(c, strategies[0])]
        care = r0.n_lit + r0.n_shadow
        dc = 100.0 * r0.n_dontcare / max(care + r0.n_dontcare, 1)
        cells = []
        for s in strategies:
            r = by[(c, s)]
            cells.append(f"{'.' if r.ok else f'{r.acne}/{r.leak}':>{w}}")
        lines.append(f"{c.id:<{cw}} {care:>5} {dc:>5.1f} " + " ".join(cells))
    summ = summarize(results)
    lines.append("")
    lines.append("cells: '.' = 0 acne and 0 leak pixels, else acne/leak pixel counts; care = labelled pixels, "
                 "dc% = don't-care share of surface pixels")
    lines.append("")
    lines.append(f"{'strategy':<{w}} {'failing':>9} {'acne':>8} {'leak':>8} {'rate %':>8} {'us/shadow ray':>14}")
    for s in strategies:
        v = summ[s]
        lines.append(f"{s:<{w}} {v['failing']:>4}/{v['cases']:<4} {v['acne']:>8} {v['leak']:>8} "
                     f"{100 * v['rate']:>8.3f} {v['us_per_ray']:>14.3f}")
    return "\n".join(lines)


def _load_callable(spec):
    mod, _, name = spec.partition(":")
    if not name:
        raise SystemExit(f"--offset must be module:function, got {spec!r}")
    return getattr(importlib.import_module(mod), name)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m pyrt.apps.acne", description=__doc__.split("\n\n")[0])
    ap.add_argument("--strategies", default=",".join(offsets.STRATEGIES),
                    help="comma-separated names from pyrt.geometry.offsets.STRATEGIES (default: all)")
    ap.add_argument("--offset", action="append", default=[],
                    help="module:function of your own offset f(surf, w) -> origins (repeatable); replaces "
                         "--strategies unless they are also given explicitly")
    ap.add_argument("--quick", action="store_true", help="base cases and sweep extremes only")
    ap.add_argument("--match", default="", help="only cases whose id contains this substring")
    ap.add_argument("--size", default="64x48", help="image size WxH (default 64x48)")
    a = ap.parse_args(argv)
    wdt, hgt = (int(x) for x in a.size.lower().split("x"))
    cases = quick_matrix() if a.quick else default_matrix()
    cases = [c for c in cases if a.match in c.id]
    strategies = []
    explicit = any(arg.startswith("--strategies") for arg in (argv if argv is not None else sys.argv[1:]))
    if not a.offset or explicit:
        strategies += [s for s in a.strategies.split(",") if s]
    strategies += [_load_callable(s) for s in a.offset]
    res = run_matrix(cases=cases, strategies=strategies, width=wdt, height=hgt, progress=sys.stderr.isatty())
    print(format_table(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
