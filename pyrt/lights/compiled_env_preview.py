"""The environment's ``strategy="preview"`` in compiled form: its tables packed after the environment's data, and the
environment's two preview lookups as scalar twins.

:func:`pack_preview` appends to the ``data`` of :func:`pyrt.lights.compiled_env.pack_environment` what the noise-free
preview reads (:func:`pyrt.integrators.direct._environment_preview`) and writes its offsets into the record
(``R_PREVIEW`` ... ``R_DFG`` of :mod:`pyrt.lights.compiled_env`):

==============  =================================================================================================
``R_PREVIEW``   1: ``preview_method="split_sum"``, 2: ``"samples"`` (0: another strategy, nothing appended)
``R_PK``        ``preview_samples`` (K); ``R_HAM``: the offset of their Hammersley points ``(K, 2)``
``R_SH``        ``SH9_COSINE_LOBE[:, None] * env.sh9()`` (9, 3): the product :func:`pyrt.shaders.envmap.
                sh9_irradiance` forms, the intensity included
``R_MAPS``      a lat-long map's prefiltered stack (:meth:`pyrt.lights.environment.Environment.prefiltered_maps`,
                however its class builds it): ``R_NLEVELS`` rows ``(alpha, h, w, offset)``, then the maps (float64)
``R_E5``        ``n`` then the diffuse loss table ``E5`` (:func:`pyrt.materials.preview.diffuse_loss_table`)
``R_DFG``       per Smith term of :data:`pyrt.shaders.jit_brdfs.GEOMETRY_TERMS` a row ``(offset, n_mu, n_r)`` of its
                ``A`` table (``B`` follows it; offset -1: not packed), then the tables of the terms the scene's
                materials use (:func:`pyrt.materials.preview.specular_tables`)
==============  =================================================================================================

Packed once per environment, light setting and set of Smith terms and kept with the environment (a weak key: like
:func:`pyrt.lights.compiled_env._packed_data`); a new intensity repacks (the SH rows carry it, as NumPy's do).
:func:`irradiance_sh` and :func:`prefiltered` are the scalar twins of :meth:`Environment.irradiance_sh` and
:meth:`Environment.prefiltered` (tests/test_compiled_preview_env.py); the estimator is the integrator's
(:mod:`pyrt.integrators.compiled_preview`).
"""
from __future__ import annotations

import weakref

import numpy as np
from numba.extending import register_jitable

from pyrt.shaders import envmap as _envmap
from pyrt.shaders import jit_brdfs as _JB
from pyrt.shaders import jit_preview as JP
from pyrt.shaders.sampling import hammersley

from pyrt.lights import compiled_env as CE
from pyrt.lights.environment import PREFILTER_ALPHAS
from pyrt.materials.preview import diffuse_loss_table, specular_tables

#: ``R_PREVIEW`` values
SPLIT_SUM, SAMPLES = 1, 2

#: environment -> (base data, maps, intensity, K, geometries, layout, data) of its last packing
_PACKED = weakref.WeakKeyDictionary()


def _parts(env, k_samples, geometries, base):
    """``(layout, data)``: ``base`` with the preview's tables appended (module docstring)."""
    parts, layout = [base], {}

    def add(arr):
        """Append ``arr`` (flattened, float64); returns its offset."""
        offset = sum(p.size for p in parts)
        parts.append(np.ravel(np.asarray(arr, dtype=np.float64)))
        return offset

    layout[CE.R_SH] = add(_envmap.SH9_COSINE_LOBE[:, None] * env.sh9())
    layout[CE.R_HAM] = add(hammersley(k_samples))
    e5 = diffuse_loss_table()
    layout[CE.R_E5] = add(np.concatenate([[e5.size], e5]))
    tables = [(g, *specular_tables(_JB.GEOMETRY_TERMS[g])) for g in geometries]
    rows = np.full((len(_JB.GEOMETRY_TERMS), 3), -1.0)
    o = sum(p.size for p in parts) + rows.size
    for g, a, b in tables:
        rows[g] = o, a.shape[0], a.shape[1]
        o += a.size + b.size
    layout[CE.R_DFG] = add(rows)
    for _, a, b in tables:
        add(a)
        add(b)
    layout[CE.R_NLEVELS] = 0
    if env.compiled_kind == "latlong":
        maps = env.prefiltered_maps()
        table = np.zeros((len(maps), 4))
        o = sum(p.size for p in parts) + table.size
        for k, mp in enumerate(maps):
            table[k] = PREFILTER_ALPHAS[k], mp.shape[0], mp.shape[1], o
            o += mp.size
        layout[CE.R_MAPS] = add(table)
        for mp in maps:
            add(mp)
        layout[CE.R_NLEVELS] = len(maps)
    return layout, np.ascontiguousarray(np.concatenate(parts))


def pack_preview(env, light, packed, geometries=()):
    """``packed`` (:func:`pyrt.lights.compiled_env.pack_environment` of ``env`` and ``light``) with the preview's
    tables when ``light`` is an :class:`pyrt.EnvironmentLight` with ``strategy="preview"`` (else unchanged):
    ``(tag, record, data)``. ``geometries``: the indices into :data:`pyrt.shaders.jit_brdfs.GEOMETRY_TERMS` of the
    Smith terms whose split-sum tables the scene's materials read."""
    if light is None or light.strategy != "preview" or packed is None:
        return packed
    tag, rec, base = packed
    geometries = tuple(sorted(set(int(g) for g in geometries)))
    maps = env.prefiltered_maps() if env.compiled_kind == "latlong" else None
    key = (base, maps, env.intensity, light.preview_samples, geometries)
    hit = _PACKED.get(env)
    if hit is not None and hit[0] is key[0] and hit[1] is key[1] and hit[2:5] == key[2:]:
        layout, data = hit[5], hit[6]
    else:
        layout, data = _parts(env, light.preview_samples, geometries, base)
        _PACKED[env] = (*key, layout, data)
    rec = rec.copy()
    rec[CE.R_PREVIEW] = SPLIT_SUM if light.preview_method == "split_sum" else SAMPLES
    rec[CE.R_PK] = light.preview_samples
    for k, v in layout.items():
        rec[k] = v
    return tag, rec, data


# ----------------------------------------------------------------------------------------- the environment's lookups

@register_jitable
def irradiance_sh(rec, data, nx, ny, nz):
    """The SH irradiance (RGB) at the unit world normal ``n``: :meth:`pyrt.lights.environment.Environment.
    irradiance_sh` (the normal in the environment's frame, :func:`pyrt.shaders.jit_preview.sh9_irradiance`)."""
    lx, ly, lz = CE.env_to_local(rec, nx, ny, nz)
    return JP.sh9_irradiance(data, int(rec[CE.R_SH]), lx, ly, lz)


@register_jitable
def prefiltered(tag, rec, data, dx, dy, dz, alpha):
    """Radiance (RGB) prefiltered with a GGX lobe of width ``alpha`` around the unit world direction ``d``:
    :meth:`pyrt.lights.environment.Environment.prefiltered` (``intensity`` times the stack's lookup in the
    environment's frame; a constant environment: its radiance, as ``ConstantEnvironment.prefiltered``)."""
    s = rec[CE.R_INTENSITY]
    if tag == CE.CONSTANT:
        return s * rec[CE.R_COLOR], s * rec[CE.R_COLOR + 1], s * rec[CE.R_COLOR + 2]
    lx, ly, lz = CE.env_to_local(rec, dx, dy, dz)
    r, g, b = JP.roughness_map_lookup(data, int(rec[CE.R_MAPS]), int(rec[CE.R_NLEVELS]), lx, ly, lz, alpha)
    return s * r, s * g, s * b


@register_jitable
def specular_ab(rec, data, geometry, mu, alpha):
    """``(A, B)`` of the split-sum tables of the Smith term ``geometry`` (an index into
    :data:`pyrt.shaders.jit_brdfs.GEOMETRY_TERMS`) at ``mu``, ``alpha``: :func:`pyrt.shaders.dfg.lookup` of the
    tables :func:`pyrt.materials.preview.schlick_albedo` reads."""
    h = int(rec[CE.R_DFG]) + 3 * geometry
    o, n_mu, n_r = int(data[h]), int(data[h + 1]), int(data[h + 2])
    return (JP.dfg_lookup(data, o, n_mu, n_r, mu, alpha),
            JP.dfg_lookup(data, o + n_mu * n_r, n_mu, n_r, mu, alpha))


@register_jitable
def diffuse_loss(rec, data, mu):
    """``E5(mu)``: :func:`pyrt.materials.preview.schlick_diffuse_loss`."""
    o = int(rec[CE.R_E5])
    return JP.dfg_lookup_1d(data, o + 1, int(data[o]), mu)


@register_jitable(forceinline=True)
def hammersley_point(rec, data, k):
    """Point ``k`` of the preview's Hammersley set (:func:`pyrt.shaders.sampling.hammersley` of ``preview_samples``)."""
    o = int(rec[CE.R_HAM]) + 2 * k
    return data[o], data[o + 1]
