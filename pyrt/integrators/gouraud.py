"""Gouraud shading: direct lighting evaluated at the vertices, radiance interpolated.

The course's three shading models side by side (``Scene.add_mesh(..., shading=...)``):

- flat: one normal per triangle, lighting at every hit;
- Phong: vertex normals interpolated (and renormalised) at the hit, lighting at every hit;
- Gouraud: lighting (the same light estimators, BRDFs and shadow rays as everywhere else) at the
  triangle's three vertices, with the vertex normals and ``wo`` toward the ray origin, and the
  resulting radiance interpolated with the hit's barycentrics,
  ``L(p) = b0 L(v0) + b1 L(v1) + b2 L(v2)``.

Emission and the ambient term stay per hit. Each hit evaluates its own three vertices (3 light
evaluations and up to 3 shadow rays per light and hit; a vertex shared by many hits is evaluated
for each), which keeps the pass a pure function of the hit batch - and is the reason Gouraud
shading is an option for comparison, not a speed-up, here. Highlights that fall between vertices
are missed and shadow edges become triangle-shaped: the artefacts the course shows.
"""
from __future__ import annotations

import numpy as np

from pyrt.geometry.accel import Hits
from pyrt.geometry.surface import surface_from_hits
from pyrt.integrators import direct
from pyrt.materials.dispatch import BSDFBatch
from pyrt.textures import apply_normal_maps

#: barycentrics (u, v) of the three vertices: hit = (1-u-v) v0 + u v1 + v v2
_VERTEX_UV = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])


def face_mask(geo, mesh_ids):
    """(F,) bool: faces of the meshes in ``mesh_ids`` (None when the set is empty)."""
    if not mesh_ids:
        return None
    return np.isin(geo.face_mesh, np.fromiter(mesh_ids, dtype=np.int64))


def vertex_rays(geo, surf, origins):
    """Hits at the three vertices of each hit's triangle, as seen from the ray ``origins``.

    Returns ``(hits, origins, dirs)`` for the 3N vertex "hits", vertex-major within each hit
    (rows ``3 j + c`` = vertex ``c`` of hit ``j``).
    """
    n = surf.n_hits
    mesh = np.repeat(surf.mesh_id, 3)
    prim = np.repeat(surf.prim_id, 3)
    uv = np.tile(_VERTEX_UV, (n, 1))
    tri = geo.faces[geo.face_offset[mesh] + prim]
    corner = np.tile(np.arange(3), n)
    pv = geo.vertices[tri[np.arange(3 * n), corner]]
    o = np.repeat(origins, 3, axis=0)
    d = pv - o
    t = np.linalg.norm(d, axis=1)
    d = d / np.where(t > 0, t, 1.0)[:, None]
    hits = Hits(hit=np.ones(3 * n, dtype=bool), t=t, mesh_id=mesh, prim_id=prim, u=uv[:, 0], v=uv[:, 1],
                ng=np.zeros((3 * n, 3)))
    return hits, o, d


def direct_light(ps, lights, visibility, surf, origins, rng):
    """Gouraud direct lighting (N, 3) at the hits of ``surf`` (all on Gouraud faces).

    The direct-lighting estimator (:func:`pyrt.integrators.direct.estimate`) runs at the three vertices of
    each hit's triangle and the results are interpolated with the hit's barycentrics.

    Parameters
    ----------
    ps : PreparedScene
        Geometry table (``ps.geo``), materials (``ps.scene.materials``), ``ps.has_normal_maps``.
    lights : list of Light
    visibility : callable
        ``visibility(surf) -> visible(idx, wi, dist, end=None)`` (:meth:`Integrator.visibility`).
    surf : SurfaceBatch
    origins : (N, 3) float64 ndarray
        The rays' origins (the viewer).
    rng : numpy.random.Generator
    """
    hits, o, d = vertex_rays(ps.geo, surf, origins)
    vsurf = surface_from_hits(ps.geo, hits, o, d, None)
    materials = ps.scene.materials
    if ps.has_normal_maps:
        apply_normal_maps(vsurf, materials)
    bsdf = BSDFBatch(vsurf, materials)
    Lv = direct.estimate(lights, vsurf, bsdf, visibility(vsurf), rng)
    return np.einsum("jc,jck->jk", surf.bary, Lv.reshape(-1, 3, 3))
