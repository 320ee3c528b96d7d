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

Modules: :mod:`~pyrt.apps.acne.truth` (exact shapes and the truth tracer), :mod:`~pyrt.apps.acne.scenes`
(the cases and their scenes), :mod:`~pyrt.apps.acne.measure` (running and scoring),
:mod:`~pyrt.apps.acne.cli` (the command line).
"""
from pyrt.apps.acne.truth import BACKGROUND, LIT, SHADOW, UNSURE, Box, LightTruth, Sphere, Truth
from pyrt.apps.acne.scenes import (GEOMETRIES, LIGHT_DISTANCE, LIGHT_RADIUS, LIGHTS, SCENE_SIZE, THIN, BuiltCase, Case,
                                   build_case, camera_rays32, default_matrix, quick_matrix, truth_labels)
from pyrt.apps.acne.measure import (CaseResult, format_table, run_case, run_matrix, strategy_name, summarize)
from pyrt.apps.acne.cli import load_callable, main

__all__ = [
    "BACKGROUND", "LIT", "SHADOW", "UNSURE", "Box", "LightTruth", "Sphere", "Truth", "GEOMETRIES", "LIGHT_DISTANCE",
    "LIGHT_RADIUS", "LIGHTS", "SCENE_SIZE", "THIN", "BuiltCase", "Case", "build_case", "camera_rays32",
    "default_matrix", "quick_matrix", "truth_labels", "CaseResult", "format_table", "run_case", "run_matrix",
    "strategy_name", "summarize", "load_callable", "main",
]
