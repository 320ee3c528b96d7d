"""Scan-like test meshes for the previewer's up-axis guess and framing (no scanned models ship with the
installed packages: trimesh's ``resources`` hold only schemas and templates, scikit-image has no meshes).

Each shape is built y-up from trimesh primitives (capsules, ellipsoids, a surface of revolution), with
*rounded* contacts (hooves, feet: no flat base, as in a scan) and, optionally, a scan-like displacement of
every vertex along its normal (Gaussian, ``noise`` times the largest extent). :func:`oriented` turns a
y-up shape into the z-up convention of CAD / scanner software (``(x, y, z) -> (x, -z, y)``, the inverse
of the previewer's ``up_transform("+z")``) and/or yaws it about its up axis.

Shapes: ``quadruped`` (body + 4 legs + neck + head + tail), ``figure`` (a standing person, arms slightly
out), ``tile`` (a flat 1 x 0.04 x 0.7 slab), ``vase`` (a surface of revolution with a base and an open rim),
``pole`` (a tall thin pole on a small foot), ``bust`` (a head on shoulders on a plinth); and the cases issue 33
found wrong on real meshes: ``alligator`` and ``flat_figure`` (2-D outlines, z = 0 everywhere: they should face
the camera), ``head_open`` / ``head_capped`` (a head-and-neck scan cut across the neck, the cut open or closed) and
``head_oblique`` / ``head_oblique_capped`` (the cut 25 degrees off the axis: the 270k-triangle igea scan lay on its
back). The outlines get no scan noise (they are drawings), the heads get theirs before the cut (a cut is exact).
"""
from __future__ import annotations

import math

import numpy as np
import trimesh


def _capsule(a, b, r):
    a, b = np.asarray(a, float), np.asarray(b, float)
    h = float(np.linalg.norm(b - a))
    c = trimesh.creation.capsule(height=h, radius=r, count=[12, 12])     # along z, centred
    z = np.array([0.0, 0.0, 1.0])
    d = (b - a) / h
    axis = np.cross(z, d)
    if np.linalg.norm(axis) > 1e-9:
        c.apply_transform(trimesh.transformations.rotation_matrix(math.acos(np.clip(z @ d, -1, 1)), axis))
    elif d[2] < 0:
        c.apply_transform(trimesh.transformations.rotation_matrix(math.pi, [1, 0, 0]))
    c.apply_translation(0.5 * (a + b))
    return c


def _ellipsoid(center, radii):
    s = trimesh.creation.icosphere(subdivisions=3)
    s.apply_scale(radii)
    s.apply_translation(center)
    return s


def quadruped():
    """A horse/cow-like animal, y-up, length along x, standing on four rounded hooves at y = 0."""
    parts = [_ellipsoid((0, 0.62, 0), (0.5, 0.2, 0.18))]
    for x in (-0.36, 0.36):
        for z in (-0.11, 0.11):
            parts.append(_capsule((x, 0.045, z), (x, 0.55, z), 0.045))
    parts += [_capsule((0.42, 0.7, 0), (0.62, 0.98, 0), 0.08), _ellipsoid((0.72, 1.0, 0), (0.16, 0.08, 0.08)),
              _capsule((-0.5, 0.65, 0), (-0.62, 0.35, 0), 0.025)]
    return trimesh.util.concatenate(parts)


def figure():
    """A standing person, y-up, 1.8 tall, feet (rounded) at y = 0."""
    parts = [_capsule((-0.1, 0.06, 0.03), (-0.1, 0.9, 0), 0.065), _capsule((0.1, 0.06, 0.03), (0.1, 0.9, 0), 0.065),
             _ellipsoid((-0.1, 0.04, 0.08), (0.05, 0.04, 0.13)), _ellipsoid((0.1, 0.04, 0.08), (0.05, 0.04, 0.13)),
             _ellipsoid((0, 1.2, 0), (0.2, 0.33, 0.12)),
             _capsule((-0.25, 1.42, 0), (-0.38, 0.85, 0), 0.045), _capsule((0.25, 1.42, 0), (0.38, 0.85, 0), 0.045),
             _ellipsoid((0, 1.66, 0), (0.1, 0.13, 0.11))]
    return trimesh.util.concatenate(parts)


def tile():
    """A flat slab 1 x 0.04 x 0.7 (y-up) with rounded (subdivided, displaced) edges."""
    b = trimesh.creation.box(extents=(1.0, 0.04, 0.7))
    b = b.subdivide().subdivide().subdivide()
    b.apply_translation((0, 0.02, 0))
    return b


def vase():
    """A vase: a surface of revolution about y (0.45 tall), a closed base, an open rim."""
    h = np.linspace(0.0, 0.45, 24)
    r = 0.09 + 0.06 * np.sin(np.pi * h / 0.45 * 1.3) + 0.02 * (h / 0.45)
    line = np.column_stack([np.r_[0.0, r], np.r_[0.0, h]])            # (radius, height): from the axis at the base
    v = trimesh.creation.revolve(line, sections=32)                   # revolves about z
    v.apply_transform(trimesh.transformations.rotation_matrix(-math.pi / 2, [1, 0, 0]))   # z -> y
    return v


def pole():
    """A tall thin pole (2 high, 0.04 wide) on a small round foot, y-up."""
    return trimesh.util.concatenate([_capsule((0, 0.05, 0), (0, 2.0, 0), 0.02),
                                     _ellipsoid((0, 0.02, 0), (0.12, 0.02, 0.12))])


def bust():
    """A head on shoulders on a square plinth, y-up."""
    plinth = trimesh.creation.box(extents=(0.3, 0.12, 0.3))
    plinth.apply_translation((0, 0.06, 0))
    return trimesh.util.concatenate([plinth, _ellipsoid((0, 0.22, 0), (0.22, 0.1, 0.12)),
                                     _capsule((0, 0.28, 0), (0, 0.38, 0), 0.05),
                                     _ellipsoid((0, 0.47, 0.01), (0.09, 0.12, 0.1))])


def _disk(cx, cy, rx, ry, n=40):
    """An elliptical disk in the plane z = 0 (a fan)."""
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    v = np.column_stack([np.r_[cx, cx + rx * np.cos(a)], np.r_[cy, cy + ry * np.sin(a)], np.zeros(n + 1)])
    k = np.arange(n)
    return trimesh.Trimesh(v, np.column_stack([np.zeros(n, int), 1 + k, 1 + (k + 1) % n]), process=False)


def _quad(pts):
    """A quadrilateral in the plane z = 0 (two triangles)."""
    return trimesh.Trimesh(np.column_stack([np.asarray(pts, float), np.zeros(4)]), [[0, 1, 2], [0, 2, 3]], process=False)


def alligator():
    """A 2-D alligator outline in the plane z = 0 (body, snout, tail, four legs; feet at y = 0), y-up."""
    parts = [_disk(0, 0.25, 0.45, 0.1), _disk(0.6, 0.25, 0.25, 0.05),
             _quad([(-0.4, 0.2), (-1.2, 0.24), (-1.2, 0.26), (-0.4, 0.3)])]
    parts += [_quad([(x - 0.04, 0.2), (x + 0.04, 0.2), (x + 0.06, 0.0), (x - 0.02, 0.0)]) for x in (-0.3, -0.2, 0.2, 0.3)]
    return trimesh.util.concatenate(parts)


def flat_figure():
    """A flat standing figure in the plane z = 0 (legs, body, arms, head; 1.8 tall, feet at y = 0), y-up."""
    return trimesh.util.concatenate([
        _quad([(-0.18, 0), (-0.02, 0), (-0.02, 0.9), (-0.18, 0.9)]), _quad([(0.02, 0), (0.18, 0), (0.18, 0.9), (0.02, 0.9)]),
        _quad([(-0.22, 0.85), (0.22, 0.85), (0.2, 1.5), (-0.2, 1.5)]),
        _quad([(-0.4, 0.9), (-0.3, 0.9), (-0.2, 1.45), (-0.28, 1.45)]),
        _quad([(0.3, 0.9), (0.4, 0.9), (0.28, 1.45), (0.2, 1.45)]), _disk(0, 1.65, 0.1, 0.13)])


def head_scan(cap=False, tilt=0.0, noise=0.003, seed=1):
    """A head-and-neck scan (y-up) cut by a plane across the neck, ``tilt`` degrees off the horizontal (about x), the
    cut open (``cap`` False) or closed by a flat cap; scan noise (``noise`` x the size, along the normals) before the
    cut, so the cut plane is exact."""
    m = trimesh.util.concatenate([_ellipsoid((0, 0.36, 0.0), (0.09, 0.12, 0.105)),
                                  _capsule((0, -0.05, -0.01), (0, 0.3, -0.01), 0.055),
                                  _ellipsoid((0, 0.27, 0.05), (0.05, 0.04, 0.05)), _ellipsoid((0, 0.36, 0.1), (0.015, 0.03, 0.02))])
    rng = np.random.default_rng(seed)
    m.vertices = m.vertices + m.vertex_normals * rng.normal(0.0, noise * float(np.max(m.extents)), (len(m.vertices), 1))
    turn = trimesh.transformations.rotation_matrix(math.radians(tilt), [1, 0, 0], point=(0, 0.1, 0))
    m.apply_transform(turn)
    v = m.vertices.copy()
    v[:, 1] = np.maximum(v[:, 1], 0.0)            # the neck's end squashed onto the plane y = 0: a flat cap
    f = m.faces
    if not cap:                                   # the cap's triangles removed: an open cut
        f = f[~np.all(v[f][:, :, 1] <= 0.0, axis=1)]
    out = trimesh.Trimesh(v, f, process=False)
    out.apply_transform(np.linalg.inv(turn))
    return out


SHAPES = {"quadruped": quadruped, "figure": figure, "tile": tile, "vase": vase, "pole": pole, "bust": bust,
          "alligator": alligator, "flat_figure": flat_figure, "head_open": head_scan,
          "head_capped": lambda: head_scan(cap=True), "head_oblique": lambda: head_scan(tilt=25.0),
          "head_oblique_capped": lambda: head_scan(cap=True, tilt=25.0)}
#: shapes that get no noise from :func:`cases` (drawings are exactly flat; the heads' noise comes before the cut)
NOISELESS = {"alligator", "flat_figure", "head_open", "head_capped", "head_oblique", "head_oblique_capped"}


def oriented(mesh, up="+y", yaw=0.0, noise=0.0, seed=0):
    """A copy of a y-up ``mesh`` authored ``up`` ("+y" or "+z"), yawed by ``yaw`` degrees about its up axis, with
    scan-like noise (``noise`` x the largest extent, along the vertex normals)."""
    m = mesh.copy()
    m.apply_transform(trimesh.transformations.rotation_matrix(math.radians(yaw), [0, 1, 0]))
    if noise > 0:
        rng = np.random.default_rng(seed)
        ext = float(np.max(m.extents))
        m.vertices = m.vertices + m.vertex_normals * rng.normal(0.0, noise * ext, (len(m.vertices), 1))
    if up == "+z":
        m.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [1, 0, 0]))   # +y -> +z
    elif up != "+y":
        raise ValueError(f"up must be '+y' or '+z', got {up!r}")
    return m


def cases(noise=0.003):
    """The measurement set: every shape, authored y-up and z-up, at yaw 0 and 30 degrees: ``(name, up, mesh)``."""
    out = []
    for name, make in SHAPES.items():
        base = make()
        for up in ("+y", "+z"):
            for k, yaw in enumerate((0.0, 30.0)):
                out.append((f"{name} {up} yaw {yaw:g}", up,
                            oriented(base, up, yaw, 0.0 if name in NOISELESS else noise, seed=k)))
    return out
