"""Integrators: they own the estimators; lights only sample, materials only evaluate.

- :mod:`pyrt.integrators.direct`: the direct-lighting estimator (light sampling for every light; for
  environment lights BSDF sampling and MIS);
- :mod:`pyrt.integrators.whitted`: :class:`Integrator`, the Whitted recursion along delta lobes in
  wavefront style (one :class:`pyrt.core.rays.RayBatch` per bounce);
- :mod:`pyrt.integrators.glossy`: :class:`GlossyIntegrator`, the same recursion plus BSDF-sampled rays at
  glossy hits, MIS-combined with light sampling (``render(..., integrator="glossy")``);
- :mod:`pyrt.integrators.gouraud`: lighting at the vertices for Gouraud-shaded meshes;
- :mod:`pyrt.integrators.media`: nested dielectrics (interface stacks, Beer-Lambert absorption);
- :mod:`pyrt.integrators.prepared`: :class:`PreparedScene` (the scene with its accelerator, built once)
  and :class:`RenderStats`.
"""
from pyrt.integrators.prepared import PreparedScene, RenderStats
from pyrt.integrators.whitted import Integrator
from pyrt.integrators.glossy import GlossyIntegrator

__all__ = ["GlossyIntegrator", "Integrator", "PreparedScene", "RenderStats"]
