"""Where float32 ray tracing loses geometry: the measured rule, a warning and a refusal.

Embree stores vertices and rays in float32 (24-bit significand, largest value ``FLOAT32_MAX`` ~ 3.4e38).
Two things go wrong, measured with pyrt's Accel (closest hits of rays toward a triangle or an icosphere):

- **Resolution.** A float32 coordinate of magnitude ``|x|`` is a multiple of ``ulp(x) ~ |x| 2^-23``
  (``np.spacing(np.float32(x))``). A unit sphere (size 2) centred at distance D renders correctly up to
  D = 1e6 (ulp 0.06: 32 steps across it), is visibly distorted at D = 1e7 (ulp 1: 2 steps, 28 % too many
  pixels) and vanishes from D = 1e8 on (ulp 8: every triangle collapses to zero area). Rule: a mesh whose
  size (its largest extent) spans fewer than :data:`RESOLVED_STEPS` float32 steps of some axis at its coordinates
  is warned about (a step there moves a vertex by that share of the mesh's size); one whose triangles all have zero
  area once rounded to float32 is lost. A thin axis alone is no risk to the image: a board 1e-7 thick at unit
  coordinates is 2 steps thick, and a step is 1e-7 of its size.
- **Overflow.** Embree's ray-triangle test multiplies a ray-origin distance by two edge vectors
  (``dot(v0 - o, cross(e1, e2))``): with ``L`` the distance from the ray origin and ``l`` the longest
  edge, hits are lost once ``L l^2`` reaches ~2.2e38 (measured for l = 2e6, 2e10, 2e12: the first miss
  is at ``L l^2 = 2.25e38`` every time; an icosphere of radius S seen from 5 S renders at S = 1e12 and
  vanishes from S ~ 1e13 on, a whole scene scaled by 1e20 is black). Rule: with ``L`` the diagonal of
  the box around every vertex and the camera, a mesh with ``L l^2 >= OVERFLOW_PRODUCT`` is lost, and
  one within a factor :data:`OVERFLOW_MARGIN` of it is warned about. Coordinates beyond ``FLOAT32_MAX``
  (infinite once cast) are refused outright.

:func:`check_range` applies both rules when a scene is prepared (:class:`pyrt.PreparedScene`): a
:class:`PrecisionWarning` names each mesh at risk or lost, and a :class:`GeometryError` is raised when
every mesh is lost (nothing could be rendered) or the camera lies beyond the float32 range.
Scaling such a scene (metres instead of light years) or re-centring it near the origin fixes both.

- **Tiny scenes.** A whole scene smaller than :data:`SMALLEST_EXTENT` (1e-8 across) is warned about: shadows
  were measured wrong from ~5e-10 on (the shadow rays' offsets, not float32 range; left unsolved).
"""
from __future__ import annotations

import warnings

import numpy as np

from pyrt.geometry.mesh_data import GeometryError
from pyrt.shaders.vec import cross

#: largest finite float32
FLOAT32_MAX = float(np.finfo(np.float32).max)
#: a mesh should span at least this many float32 steps at its coordinates (64: shape errors below 1.6 %)
RESOLVED_STEPS = 64
#: ``L l^2`` (m^3) at which Embree's float32 ray-triangle test overflows and hits are lost (measured 2.25e38)
OVERFLOW_PRODUCT = 2.0e38
#: warn when ``L l^2`` is within this factor of :data:`OVERFLOW_PRODUCT`
OVERFLOW_MARGIN = 100.0
#: scenes (camera included) smaller than this are warned about: measured, a plane + sphere + point light scene
#: scaled by S shades exactly like S = 1 down to S = 1e-9 (extent 5e-9) and wrongly from S = 1e-10 on (30 % of
#: the pixels wrongly in shadow, whatever robust offset strategy; the shadow rays' offsets, not float32 range)
SMALLEST_EXTENT = 1e-8


class PrecisionWarning(RuntimeWarning):
    """A mesh lies where float32 ray tracing distorts or loses it (see :mod:`pyrt.geometry.precision`)."""


def check_range(meshes, camera_position):
    """Warn about meshes float32 ray tracing distorts or loses; refuse a scene where nothing can be rendered.

    Parameters
    ----------
    meshes : list of MeshData
        World-space meshes (float32-exact float64 vertices, as :meth:`pyrt.Scene.add_mesh` stores them).
    camera_position : (3,) float ndarray

    Raises
    ------
    GeometryError
        Every mesh is lost, or the camera lies beyond the float32 range.
    """
    cam = np.asarray(camera_position, dtype=np.float64)
    if not np.all(np.abs(cam) < FLOAT32_MAX):
        raise GeometryError(f"the camera position {cam.tolist()} lies beyond the float32 range (|x| < 3.4e38) "
                            "Embree traces rays in")
    lo = np.minimum.reduce([m.vertices.min(axis=0) for m in meshes] + [cam])
    hi = np.maximum.reduce([m.vertices.max(axis=0) for m in meshes] + [cam])
    extent = float(np.linalg.norm(hi - lo))
    if 0 < extent < SMALLEST_EXTENT:
        warnings.warn(f"the scene is {extent:.3g} across: below {SMALLEST_EXTENT:g} shadows were measured wrong "
                      "(ray offsets); scale it nearer to unit size", PrecisionWarning, stacklevel=3)
    lost = []
    for m in meshes:
        problem, fatal = _mesh_problem(m.vertices, m.faces, extent, m.vertices_object)
        if problem is None:
            continue
        if fatal:
            lost.append(m.name)
        warnings.warn(f"mesh {m.name!r}: {problem}", PrecisionWarning, stacklevel=3)
    if len(lost) == len(meshes):
        raise GeometryError(f"nothing can be rendered: float32 ray tracing loses every mesh ({', '.join(map(repr, lost))});"
                            " scale the scene nearer to unit size or move it nearer to the origin")


def _mesh_problem(v, f, extent, v_object):
    """``(message, lost)`` for one mesh under the two rules, or ``(None, False)``."""
    mag = float(np.max(np.abs(v)))
    if not mag < FLOAT32_MAX:
        return "coordinates beyond the float32 range (|x| < 3.4e38)", True
    v32 = v.astype(np.float32).astype(np.float64)
    sizes = v32.max(axis=0) - v32.min(axis=0)
    ulps = np.spacing(np.max(np.abs(v32), axis=0).astype(np.float32)).astype(np.float64)
    # the mesh's size in float32 steps of each axis (a step moves a vertex by ulp / size of the mesh's size); a flat
    # mesh's axis of size 0 is exact (no steps to count), a solid one's (rank 3 in object space, and an invertible
    # transform keeps the rank) was flattened by float32 rounding: counted
    solid = np.linalg.matrix_rank(v_object - v_object.mean(axis=0)) == 3
    big = float(sizes.max())
    steps = np.where((sizes > 0) | solid, big / ulps, np.inf)
    k = int(np.argmin(steps))
    size, ulp = float(sizes[k]), float(ulps[k])
    # Per-triangle work only where it can change the answer (multi-million-triangle meshes): every edge lies in
    # the bounding box, so its diagonal bounds the longest edge, and when even that bound keeps L l^2 a factor
    # OVERFLOW_MARGIN below the overflow the exact edge is not needed; and one triangle of non-zero float32 area
    # (looked for among the first faces before all of them) shows the mesh is not lost.
    diag = float(np.linalg.norm(sizes))
    if extent * diag * diag * OVERFLOW_MARGIN < OVERFLOW_PRODUCT:
        edge = product = None
    else:
        edge = float(np.sqrt(max(float(np.max(np.einsum("ij,ij->i", e, e))) for e in _edges(v32, f))))
        product = extent * edge * edge
    if not any(_any_area(v32, g) for g in (f[:_WITNESS_FACES], f[_WITNESS_FACES:])):
        return (f"size {size:.3g} is below the float32 step {ulp:.3g} at its coordinates (|x| up to {mag:.3g}): "
                "every triangle collapses and the mesh is lost"), True
    if product is not None and product >= OVERFLOW_PRODUCT:
        return (f"scene extent {extent:.3g} x longest edge {edge:.3g} squared = {product:.3g} overflows Embree's "
                "float32 intersection test (>= 2e38): the mesh is lost"), True
    if steps[k] < RESOLVED_STEPS:
        return (f"its size {big:.3g} spans only {steps[k]:.3g} float32 steps of {ulp:.3g} along {'xyz'[k]} at its "
                f"coordinates (|x| up to {mag:.3g}; {RESOLVED_STEPS} needed; its size {size:.3g} along {'xyz'[k]}): its "
                "shape is distorted or flattened"), False
    if product is not None and product * OVERFLOW_MARGIN >= OVERFLOW_PRODUCT:
        return (f"scene extent {extent:.3g} x longest edge {edge:.3g} squared = {product:.3g} is within "
                f"{OVERFLOW_MARGIN:g}x of the float32 overflow of Embree's intersection test (2e38)"), False
    return None, False


#: faces searched first for a triangle of non-zero float32 area (:func:`_mesh_problem`)
_WITNESS_FACES = 4096


def _edges(v, f):
    """The three edge vectors (F, 3) of every face (three gathers, no (3F, 3) copy)."""
    p0, p1, p2 = (np.take(v, f[:, j], axis=0) for j in range(3))
    return p1 - p0, p2 - p1, p0 - p2


def _any_area(v, f):
    """True if some face of ``f`` has a non-zero cross product of its edges (in the float64 values of ``v``)."""
    if f.shape[0] == 0:
        return False
    e01, _, e20 = _edges(v, f)
    n = cross(e01, -e20)
    return bool(np.any(np.einsum("ij,ij->i", n, n) > 0))
