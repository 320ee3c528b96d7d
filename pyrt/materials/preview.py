"""What the split-sum environment preview needs of a material: its reflection as lobes.

:meth:`pyrt.materials.Material.preview_lobes` returns a :class:`PreviewLobes` (or None: the preview then samples
the material's BSDF, see :mod:`pyrt.lights.environment`): a Lambertian part, lit by the environment's SH
irradiance, and GGX lobes, each lit by the environment prefiltered with its width at its dominant direction and
weighted by its directional albedo (the split sum, :mod:`shaders.dfg`). The helpers here give those albedos from
tables shipped with pyrt (:data:`TABLES_FILE`, read on first use) or, for a geometry term not shipped, built once
per process (about 0.15 s).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from pyrt.shaders import dfg


@dataclass
class GlossyLobe:
    """A GGX reflection lobe as the preview sees it: ``weight`` (N, 3) its directional albedo (Fresnel included),
    ``alpha`` (N,) its width, ``normal`` (N, 3) the world normal it reflects about (None: the shading normal)."""

    weight: np.ndarray
    alpha: np.ndarray
    normal: np.ndarray | None = None


@dataclass
class PreviewLobes:
    """A material's reflection at a batch of hits, for the split-sum preview.

    ``diffuse`` (N, 3): the albedo of a Lambertian part (lit by ``E(n_s) / pi``); ``glossy``: the GGX lobes;
    ``occlusion`` (N,) or None: a factor on the whole environment term (glTF occlusion maps, which apply to
    image-based light)."""

    diffuse: np.ndarray
    glossy: list = field(default_factory=list)
    occlusion: np.ndarray | None = None

    def scaled(self, k):
        """The lobes times ``k`` (N,) (a coat's ``1 - c F`` on the layer below it)."""
        k = np.asarray(k, dtype=np.float64)[:, None]
        return PreviewLobes(self.diffuse * k, [GlossyLobe(lb.weight * k, lb.alpha, lb.normal) for lb in self.glossy],
                            self.occlusion)


#: the tables of :func:`shaders.dfg.specular_albedo_tables` (default grid and samples) for :data:`SHIPPED_GEOMETRIES`
#: and :func:`shaders.dfg.schlick_diffuse_loss_table`, written by ``tools/make_tables.py`` (tests/test_split_sum.py
#: checks them against a fresh build): read in ~1 ms instead of built in ~0.15 s by every preview process
TABLES_FILE = Path(__file__).with_name("dfg_tables.npz")
#: the Smith terms whose tables are shipped (the glTF materials' and the clear coat's)
SHIPPED_GEOMETRIES = ("smith_separable", "smith_correlated")


@lru_cache(maxsize=None)
def _shipped():
    """The arrays of :data:`TABLES_FILE` ({} when it is missing or unreadable: the tables are then built)."""
    try:
        with np.load(TABLES_FILE) as f:
            return {k: f[k] for k in f.files}
    except (OSError, ValueError):
        return {}


@lru_cache(maxsize=None)
def _ab(geometry):
    t = _shipped()
    if f"A_{geometry}" in t:
        return t[f"A_{geometry}"], t[f"B_{geometry}"]
    return dfg.specular_albedo_tables(geometry=geometry)


@lru_cache(maxsize=None)
def _e5():
    t = _shipped()
    return t["E5"] if "E5" in t else dfg.schlick_diffuse_loss_table()


def specular_tables(geometry):
    """``(A, B)`` (32, 32) each: the tables :func:`schlick_albedo` reads for the Smith term ``geometry`` (shipped, or
    built once per process); the compiled preview packs these (:mod:`pyrt.lights.compiled_env_preview`)."""
    return _ab(geometry)


def diffuse_loss_table():
    """``E5`` (32,): the table :func:`schlick_diffuse_loss` reads."""
    return _e5()


def write_tables(path=TABLES_FILE):
    """Build the shipped tables (:data:`SHIPPED_GEOMETRIES`, E5) and write them to ``path`` (tools/make_tables.py)."""
    arrays = {"E5": dfg.schlick_diffuse_loss_table()}
    for g in SHIPPED_GEOMETRIES:
        arrays[f"A_{g}"], arrays[f"B_{g}"] = dfg.specular_albedo_tables(geometry=g)
    np.savez_compressed(path, **arrays)
    return path


def view_cosine(ctx, normal=None):
    """``n . wo`` (N,) at the hits of ``ctx``, clamped to [1e-4, 1] (the tables' domain)."""
    n = ctx.ns if normal is None else normal
    return np.clip(np.einsum("ij,ij->i", ctx.wo, n), 1e-4, 1.0)


def schlick_albedo(f0, mu, alpha, geometry):
    """Directional albedo ``F0 A + B`` (N, 3) of a GGX lobe with Schlick Fresnel ``f0`` ((3,) or (N, 3))."""
    A, B = _ab(geometry)
    a = dfg.lookup(A, mu, alpha)[:, None]
    b = dfg.lookup(B, mu, alpha)[:, None]
    return np.asarray(f0, dtype=np.float64) * a + b


def fresnel_free_albedo(mu, alpha, geometry):
    """Directional albedo ``A + B`` (N,) of a GGX lobe without Fresnel (<= 1)."""
    A, B = _ab(geometry)
    return dfg.lookup(A, mu, alpha) + dfg.lookup(B, mu, alpha)


def schlick_diffuse_loss(mu):
    """``E5(mu)`` (N, 1): the cosine-weighted mean of ``(1 - v.h)^5`` (a diffuse lobe under ``1 - F(v.h)``)."""
    return dfg.lookup_1d(_e5(), mu)[:, None]
