"""The common base of every error pyrt raises.

Each family has its own class (``MaterialError``, ``LightError``, ``SceneFileError`` ...); all derive from
:class:`Error`, so ``except pyrt.Error`` catches anything pyrt rejects, and the parameter errors also
derive from :class:`ValueError` (what they are, and what callers caught before the common base existed).
A message names the object and the problem: ``"Lambert(floor): albedo must be in [0, 1], got [1.2, 0, 0]"``.
"""
from __future__ import annotations


class Error(Exception):
    """Base class of every pyrt error."""


class RenderError(Error, ValueError):
    """An invalid render option (``spp``, ``max_depth``, ``throughput_cutoff``, ``threads``, ...)."""
