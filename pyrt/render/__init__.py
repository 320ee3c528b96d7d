"""Rendering: prepare a scene, shade camera samples in chunks on a thread pool, accumulate a Film.

- :mod:`~pyrt.render.fixed`: :func:`render` / :func:`render_full` at a fixed number of samples per pixel
  (and the dispatch to adaptive rendering when a target error, a time budget or a sample cap is given);
- :mod:`~pyrt.render.adaptive`: progressive passes that spend samples where the estimated error is high;
- :mod:`~pyrt.render.pool`: the chunk pool (index-order collection: thread-count independent images);
- :mod:`~pyrt.render.result`: :class:`RenderResult`;
- :mod:`~pyrt.render.settings`: the option objects (:class:`Whitted`, :class:`Glossy`, :class:`Sampling`,
  :class:`Output`, :class:`Execution`).
"""
from pyrt.render.fixed import INTEGRATORS, render, render_full
from pyrt.integrators.whitted import SAMPLERS
from pyrt.render.result import RenderResult
from pyrt.render.settings import Execution, Glossy, Output, Sampling, Whitted

__all__ = ["INTEGRATORS", "SAMPLERS", "Execution", "Glossy", "Output", "RenderResult", "Sampling", "Whitted", "render",
           "render_full"]
