"""The environment's compiled form: a tag, a parameter record, flat tables, and the scalar lookup / sampling twins.

:func:`pack_environment` turns a :class:`pyrt.ConstantEnvironment` or a :class:`pyrt.LatLongEnvironment` (either
filter) and, optionally, the :class:`pyrt.EnvironmentLight` that lights with it into ``(tag, record, data)``; any
other environment (cube maps, light probes, subclasses that do not declare their ``compiled_kind``) gives None (the
render then takes the NumPy path). The
functions below are ``numba.extending.register_jitable``: callable from nopython code and from plain Python; each
is the scalar form of the NumPy method named in its docstring, for ONE direction or ONE ``u``, and
tests/test_compiled_env.py holds each to it (1e-6 relative; the same ``u`` gives the same direction and pdf) and
runs a chi-square test of the compiled samplers against their compiled pdfs.

Tags: :data:`CONSTANT`, :data:`LATLONG_BILINEAR` (``filter="bilinear"``, the default: bilinear lookups, the dual-cell
table of :mod:`pyrt.shaders.envmap_bilinear`), :data:`LATLONG_NEAREST` (``filter="nearest"``: texel lookups, the
texel table of :func:`pyrt.shaders.envmap.latlong_sample`).

The record (float64, :data:`RECORD` entries; names are the offsets):

==================  =================================================================================================
``R_INTENSITY``     ``Environment.intensity``
``R_ROT`` (9)       ``Environment.rotation`` (world_from_env), row-major: local = ``d @ R``, world = ``d @ R.T``
``R_COLOR`` (3)     ``ConstantEnvironment.color``
``R_BACKGROUND``    (3) ``Environment.background``; ``R_HIDE``: ``hide_background`` (1/0)
``R_H, R_W``        the image's height and width (lat-long)
``R_ROWS``          rows of the sampling tables: ``H + 1`` (bilinear dual cells), ``H`` (nearest)
``R_F32``           1 when the image is float32 (a bilinear lookup is rounded to float32, as NumPy's is)
``R_COMPENSATE``    the light's ``compensate`` (1/0: :func:`mis_sample` uses the compensated table)
``R_BETA``          2 (power heuristic) or 1 (balance); ``R_NL``, ``R_NB``: the counts the weights use (1, 1 when
                    ``n_samples == bsdf_samples``, as :meth:`EnvironmentLight.mis_weights`)
``R_INTEGRAL``      the full table's ``integral``; ``R_C_INTEGRAL`` the compensated one's; ``R_HAS_C`` 1 when the
                    compensated table exists (0: the light half of MIS has density 0 everywhere)
``R_IMAGE``...      offsets into ``data`` of the image (``R_IMAGE``), the luminance (``R_LUM``), the full table
                    (``R_TABLE``) and the compensated table (``R_C_TABLE``)
``R_PREVIEW``...    ``strategy="preview"``: its method and the offsets of its tables in ``data``
                    (:mod:`pyrt.lights.compiled_env_preview`, which appends them)
==================  =================================================================================================

``data`` (float64, flat): the image ``(H, W, 3)`` row-major; for bilinear maps the clamped luminance ``(H, W)`` (the
corners of the dual cells); each table as its ``func`` ``(rows, W)``, ``cdf_cond`` ``(rows, W + 1)`` and
``cdf_marg`` ``(rows + 1,)`` (:class:`pyrt.shaders.distribution.Distribution2D`) followed by the guide tables of
its searches, ``(rows, G + 1)`` for the rows and ``(Gm + 1,)`` for the marginal (:func:`guide_buckets` of ``W``
and ``rows``; :func:`guide_table`), back to back. A constant environment has no data (a one-element array).

The packed data of a lat-long map (image, luminance, tables, guides: 8.4 MB for 512 x 256) is built once per
map and light setting and kept with the environment (:func:`pack_environment` rebuilds it when the image or the
tables are new objects); the record is built on every call.
"""
from __future__ import annotations

import math
import weakref

import numpy as np
from numba.extending import register_jitable

from pyrt.core import unmanaged as U
from pyrt.shaders import jit as J
from pyrt.shaders.jit_math import sincos
from pyrt.shaders.jit_preview import bilinear_latlong, latlong_dir_to_uv

from pyrt.lights.compiled_tables import BELOW_ONE, cell_pdf, guide_table, sample_cells
from pyrt.materials.compiled_sampling import power_heuristic, square_to_uniform_sphere

#: tags (0: no environment)
CONSTANT, LATLONG_BILINEAR, LATLONG_NEAREST = 1, 2, 3
#: record entries
RECORD = 40
R_INTENSITY, R_ROT, R_COLOR, R_BACKGROUND, R_HIDE = 0, 1, 10, 13, 16
R_H, R_W, R_ROWS, R_F32 = 17, 18, 19, 20
R_COMPENSATE, R_BETA, R_NL, R_NB = 21, 22, 23, 24
R_INTEGRAL, R_C_INTEGRAL, R_HAS_C = 25, 26, 27
R_IMAGE, R_LUM, R_TABLE, R_C_TABLE = 28, 29, 30, 31
#: the preview's entries (:mod:`pyrt.lights.compiled_env_preview`; all 0 under ``strategy="mis"``)
R_PREVIEW, R_PK, R_SH, R_MAPS, R_NLEVELS, R_HAM, R_E5, R_DFG = 32, 33, 34, 35, 36, 37, 38, 39

INV_2PI2 = 1.0 / (2.0 * math.pi * math.pi)
INV_4PI = 1.0 / (4.0 * math.pi)


# ----------------------------------------------------------------------------------------- packing

def _table(dist):
    """A :class:`Distribution2D`'s ``func``, ``cdf_cond``, ``cdf_marg`` and their guide tables flattened back to
    back (module docstring)."""
    rows = dist.cdf_cond.shape[0]
    return [np.ravel(dist.func), np.ravel(dist.cdf_cond), np.ravel(dist.cdf_marg),
            np.ravel(guide_table(dist.cdf_cond, np.arange(rows, dtype=np.float64))),
            np.ravel(guide_table(dist.cdf_marg, 0.0))]


#: environment -> (image, tables, layout, data) of its last packing (:func:`_packed_data`)
_PACKED = weakref.WeakKeyDictionary()


def _packed_data(env, bilinear, dist, comp):
    """``(layout, data)`` of a lat-long ``env``'s image and tables (``layout``: the record's offsets), packed once
    and reused while the environment keeps the same image and table objects."""
    img = env.image
    hit = _PACKED.get(env)
    if hit is not None and hit[0] is img and hit[1] is dist and hit[2] is comp:
        return hit[3], hit[4]
    h, w = img.shape[:2]
    parts = [np.ravel(np.asarray(img, dtype=np.float64))]
    if bilinear:
        parts.append(np.ravel(env.bilinear_table.c[:h]))       # the clamped luminance (each cell's bottom corners)
    parts += _table(dist)
    if comp is not None:
        parts += _table(comp)
    sizes = np.cumsum([0] + [p.size for p in parts])
    k = 2 if bilinear else 1
    layout = {R_IMAGE: sizes[0], R_LUM: sizes[1] if bilinear else 0, R_TABLE: sizes[k],
              R_C_TABLE: sizes[k + 5] if comp is not None else 0}
    data = np.ascontiguousarray(np.concatenate(parts))
    _PACKED[env] = (img, dist, comp, layout, data)
    return layout, data


def packable(env):
    """True when :func:`pack_environment` gives ``env`` a compiled form: its class declares
    :attr:`pyrt.lights.environment.Environment.compiled_kind` ``"constant"`` (:class:`pyrt.ConstantEnvironment`) or
    ``"latlong"`` (:class:`pyrt.LatLongEnvironment`, bilinear or nearest, and subclasses that declare it again, such
    as the previewer's ``StudioEnvironment``, which only builds its prefiltered stack its own way). The attribute is
    not inherited: a subclass that overrides the radiance or the sampling is not taken for its base (no method
    comparison: what the kernel reads is declared, not probed); the preview reads every subclass's own SH and
    prefiltered stack (:mod:`pyrt.lights.compiled_env_preview`)."""
    return env.compiled_kind == "constant" or (env.compiled_kind == "latlong" and env.filter in ("bilinear", "nearest"))


def pack_environment(env, light=None):
    """``(tag, record, data)`` of ``env`` for the compiled kernel (module docstring), or None when it has no compiled
    form (:func:`packable`).

    ``light``: the :class:`pyrt.EnvironmentLight` lighting with ``env`` (its ``compensate``, ``heuristic``,
    ``n_samples`` and ``bsdf_samples`` go into the record), or None (no compensation, power heuristic, 1 + 1).
    The tables are the light's own (``env.distribution``, ``env.compensated_distribution``), built once by the
    environment and shared with the NumPy path."""
    rec = np.zeros(RECORD)
    rec[R_INTENSITY] = env.intensity
    rec[R_ROT:R_ROT + 9] = np.asarray(env.rotation, dtype=np.float64).ravel()
    rec[R_BACKGROUND:R_BACKGROUND + 3] = np.broadcast_to(np.asarray(env.background, dtype=np.float64), (3,))
    rec[R_HIDE] = 1.0 if env.hide_background else 0.0
    rec[R_BETA] = 2.0
    rec[R_NL] = rec[R_NB] = 1.0
    if light is not None:
        if light.environment is not env:
            raise ValueError(f"pack_environment: {light.label} lights with another environment")
        rec[R_COMPENSATE] = 1.0 if light.compensate else 0.0
        rec[R_BETA] = 2.0 if light.heuristic == "power" else 1.0
        if light.n_samples != light.bsdf_samples:
            rec[R_NL], rec[R_NB] = light.n_samples, light.bsdf_samples
    if env.compiled_kind == "constant":
        rec[R_COLOR:R_COLOR + 3] = np.broadcast_to(np.asarray(env.color, dtype=np.float64), (3,))
        return CONSTANT, rec, np.zeros(1)
    if not packable(env):
        return None
    img = env.image
    h, w = img.shape[:2]
    rec[R_H], rec[R_W] = h, w
    rec[R_F32] = 1.0 if img.dtype == np.float32 else 0.0
    bilinear = env.filter == "bilinear"
    dist, comp = env.distribution, env.compensated_distribution
    if bilinear and comp is not None:
        comp = comp.dist
    rec[R_ROWS] = dist.func.shape[0]
    rec[R_INTEGRAL] = dist.integral
    if comp is not None:
        rec[R_HAS_C], rec[R_C_INTEGRAL] = 1.0, comp.integral
    layout, data = _packed_data(env, bilinear, dist, comp)
    for key, value in layout.items():
        rec[key] = value
    return (LATLONG_BILINEAR if bilinear else LATLONG_NEAREST), rec, data


# ----------------------------------------------------------------------------------------- frames and mapping

@register_jitable(forceinline=True)
def env_to_local(rec, dx, dy, dz):
    """World direction -> the environment's frame, ``d @ R`` (:meth:`pyrt.lights.environment.Environment.to_local`)."""
    b = R_ROT
    return (dx * rec[b] + dy * rec[b + 3] + dz * rec[b + 6], dx * rec[b + 1] + dy * rec[b + 4] + dz * rec[b + 7],
            dx * rec[b + 2] + dy * rec[b + 5] + dz * rec[b + 8])


@register_jitable(forceinline=True)
def env_to_world(rec, dx, dy, dz):
    """The environment's frame -> world, ``d @ R.T`` (:meth:`pyrt.lights.environment.Environment.to_world`)."""
    b = R_ROT
    return (dx * rec[b] + dy * rec[b + 1] + dz * rec[b + 2], dx * rec[b + 3] + dy * rec[b + 4] + dz * rec[b + 5],
            dx * rec[b + 6] + dy * rec[b + 7] + dz * rec[b + 8])


@register_jitable(forceinline=True)
def latlong_uv_to_dir(u, v):
    """The unit direction of lat-long ``(u, v)``: :func:`pyrt.shaders.envmap.latlong_uv_to_dir`."""
    x, y, z, _ = latlong_uv_to_dir_st(u, v)
    return x, y, z


@register_jitable(forceinline=True)
def latlong_uv_to_dir_st(u, v):
    """:func:`latlong_uv_to_dir` and ``sin(pi v)`` (the sine it computes), ``(x, y, z, st)``; the sines and cosines
    by :func:`pyrt.shaders.jit_math.sincos` (within 3e-16 of libm's)."""
    st, ct = sincos(math.pi * v)
    sp, cp = sincos(2.0 * math.pi * u)
    return sp * st, ct, -cp * st, st


# ----------------------------------------------------------------------------------------- radiance

@register_jitable
def latlong_lookup(tag, rec, data, u, v):
    """The map's texel value (RGB, no intensity) at lat-long ``(u, v)``: :func:`pyrt.shaders.envmap.latlong_lookup`
    (``lookup_bilinear`` / ``lookup_nearest`` wrapping in u, clamping in v; a float32 image's bilinear blend rounded
    to float32)."""
    h, w = int(rec[R_H]), int(rec[R_W])
    o = int(rec[R_IMAGE])
    tv = 1.0 - v                              # the texture's v (up)
    x = u * w - 0.5
    y = (1.0 - tv) * h - 0.5
    if tag == LATLONG_NEAREST:
        ix = J.wrap_int(int(math.floor(x + 0.5)), w)
        iy = min(max(int(math.floor(y + 0.5)), 0), h - 1)
        t = o + 3 * (iy * w + ix)
        return data[t], data[t + 1], data[t + 2]
    r, g, b = bilinear_latlong(data, o, h, w, u, v)
    if rec[R_F32] != 0.0:
        return np.float64(np.float32(r)), np.float64(np.float32(g)), np.float64(np.float32(b))
    return r, g, b


@register_jitable
def radiance(tag, rec, data, dx, dy, dz):
    """Radiance (RGB) arriving from the unit world direction ``d``: :meth:`pyrt.lights.environment.Environment.
    radiance` (``intensity`` times the map in the environment's frame)."""
    s = rec[R_INTENSITY]
    if tag == CONSTANT:
        return s * rec[R_COLOR], s * rec[R_COLOR + 1], s * rec[R_COLOR + 2]
    lx, ly, lz = env_to_local(rec, dx, dy, dz)
    u, v = latlong_dir_to_uv(lx, ly, lz)
    r, g, b = latlong_lookup(tag, rec, data, u, v)
    return s * r, s * g, s * b


@register_jitable
def missed(tag, rec, data, dx, dy, dz, primary):
    """Radiance of a ray that misses everything: the environment, or its ``background`` for camera rays
    (``primary``) when ``hide_background`` is set (:meth:`pyrt.integrators.whitted.WhittedIntegrator.background`)."""
    if primary and rec[R_HIDE] != 0.0:
        return rec[R_BACKGROUND], rec[R_BACKGROUND + 1], rec[R_BACKGROUND + 2]
    return radiance(tag, rec, data, dx, dy, dz)


# ----------------------------------------------------------------------------------------- lat-long sampling

@register_jitable(forceinline=True)
def _corners(rec, data, k, i):
    """The luminances ``(a, b, c, d)`` at the corners of dual cell ``(k, i)`` (:class:`pyrt.shaders.
    envmap_bilinear.BilinearTable`: top left, top right, bottom left, bottom right)."""
    h, w = int(rec[R_H]), int(rec[R_W])
    o = int(rec[R_LUM])
    top, bottom = min(max(k - 1, 0), h - 1) * w, min(max(k, 0), h - 1) * w
    i1 = J.wrap_int(i + 1, w)
    return data[o + top + i], data[o + top + i1], data[o + bottom + i], data[o + bottom + i1]


@register_jitable(forceinline=True)
def _v_extent(h, k):
    """``(v0, v1)`` of dual-cell row ``k`` (:func:`pyrt.shaders.envmap_bilinear.bilinear_table`)."""
    return min(max((k - 0.5) / h, 0.0), 1.0), min(max((k + 0.5) / h, 0.0), 1.0)


@register_jitable
def sample_linear(u, a, b):
    """``x`` in [0, 1) of density ``(1 - x) a + x b``: :func:`pyrt.shaders.envmap_bilinear.sample_linear`."""
    den = a + math.sqrt((1.0 - u) * a * a + u * b * b)
    x = u
    if den > 0.0:
        x = u * (a + b) / den
    return min(max(x, 0.0), BELOW_ONE)


@register_jitable
def _density_uv(rec, data, o, integral, k, i, s, t):
    """Area density on [0, 1)^2 at ``(s, t)`` of dual cell ``(k, i)`` of the table at ``data[o:]``:
    :func:`pyrt.shaders.envmap_bilinear._density_uv`."""
    h, w = int(rec[R_H]), int(rec[R_W])
    v0, v1 = _v_extent(h, k)
    area_scale = (h + 1) * (v1 - v0)
    if integral <= 0.0:
        return 1.0 / area_scale
    a, b, c, d = _corners(rec, data, k, i)
    return _density_corners(data, o, integral, w, k, i, s, t, area_scale, a, b, c, d)


@register_jitable(forceinline=True)
def _density_corners(data, o, integral, w, k, i, s, t, area_scale, a, b, c, d):
    """:func:`_density_uv` of a table with a positive integral, given the cell's ``area_scale`` and corners."""
    mean = 0.25 * (a + b + c + d)
    bil = (1.0 - s) * (1.0 - t) * a + s * (1.0 - t) * b + (1.0 - s) * t * c + s * t * d
    ratio = bil / mean if mean > 0.0 else 0.0
    return data[o + k * w + i] / integral / area_scale * ratio


@register_jitable
def sample_table(tag, rec, data, o, integral, u0, u1):
    """A direction in the environment's frame and its solid-angle density, ``(x, y, z, pdf)``, from the lat-long
    table at ``data[o:]``: :func:`pyrt.shaders.envmap_bilinear.sample` (LATLONG_BILINEAR) or
    :func:`pyrt.shaders.envmap.latlong_sample` (LATLONG_NEAREST)."""
    x, y, z, p, _, _ = sample_table_uv(tag, rec, data, o, integral, u0, u1)
    return x, y, z, p


@register_jitable
def sample_table_uv(tag, rec, data, o, integral, u0, u1):
    """:func:`sample_table` and the direction's lat-long coordinates as sampled, ``(x, y, z, pdf, u, v)`` (what
    :func:`latlong_dir_to_uv` of the direction gives back up to rounding)."""
    h, w, rows = int(rec[R_H]), int(rec[R_W]), int(rec[R_ROWS])
    k, i, fu, fv = sample_cells(data, o, rows, w, u0, u1)
    if tag == LATLONG_NEAREST:
        u = (i + fu) / w
        v = (k + fv) / h
        p = cell_pdf(data, o, integral, w, k, i)
    else:
        v0, v1 = _v_extent(h, k)
        if integral > 0.0:
            a, b, c, d = _corners(rec, data, k, i)
            t = sample_linear(fv, a + b, c + d)
            s = sample_linear(fu, (1.0 - t) * a + t * c, (1.0 - t) * b + t * d)
            p = _density_corners(data, o, integral, w, k, i, s, t, (h + 1) * (v1 - v0), a, b, c, d)
        else:
            s, t = fu, fv
            p = _density_uv(rec, data, o, integral, k, i, s, t)
        u = (i + 0.5 + s) / w
        u = u - math.floor(u)
        v = v0 + t * (v1 - v0)
    x, y, z, st = latlong_uv_to_dir_st(u, v)
    return x, y, z, (p * INV_2PI2 / st if st > 0.0 else 0.0), u, v


@register_jitable
def pdf_table(tag, rec, data, o, integral, x, y, z):
    """Solid-angle density of :func:`sample_table` at the unit direction ``(x, y, z)`` (environment frame):
    :func:`pyrt.shaders.envmap_bilinear.pdf` / :func:`pyrt.shaders.envmap.latlong_pdf`."""
    u, v = latlong_dir_to_uv(x, y, z)
    return pdf_table_uv(tag, rec, data, o, integral, x, y, z, u, v)


@register_jitable
def pdf_table_uv(tag, rec, data, o, integral, x, y, z, u, v):
    """:func:`pdf_table` with the direction's lat-long coordinates ``(u, v)`` (:func:`latlong_dir_to_uv`) given."""
    h, w = int(rec[R_H]), int(rec[R_W])
    if tag == LATLONG_NEAREST:
        col = min(max(int(math.floor(u * w)), 0), w - 1)
        row = min(max(int(math.floor(v * h)), 0), h - 1)
        p = cell_pdf(data, o, integral, w, row, col)
    else:
        xx = u * w - 0.5
        fx = math.floor(xx)
        i = J.wrap_int(int(fx), w)
        s = xx - fx
        k = min(max(int(math.floor(v * h - 0.5)) + 1, 0), h)
        v0, v1 = _v_extent(h, k)
        t = min(max((v - v0) / (v1 - v0), 0.0), 1.0)
        p = _density_uv(rec, data, o, integral, k, i, s, t)
    st = math.sqrt(max(0.0, x * x + z * z))
    return p * INV_2PI2 / st if st > 0.0 else 0.0


# ----------------------------------------------------------------------------------------- the light's techniques

@register_jitable
def sample(tag, rec, data, u0, u1):
    """An importance-sampled world direction and its density, ``(x, y, z, pdf)``: :meth:`pyrt.lights.environment.
    Environment.sample` (constant: the uniform sphere; lat-long: the full table)."""
    if tag == CONSTANT:
        x, y, z = square_to_uniform_sphere(u0, u1)
        p = INV_4PI
    else:
        x, y, z, p = sample_table(tag, rec, data, int(rec[R_TABLE]), rec[R_INTEGRAL], u0, u1)
    wx, wy, wz = env_to_world(rec, x, y, z)
    return wx, wy, wz, p


@register_jitable
def pdf(tag, rec, data, dx, dy, dz):
    """Density of :func:`sample` at the unit world direction ``d``: :meth:`pyrt.lights.environment.Environment.pdf`."""
    if tag == CONSTANT:
        return INV_4PI
    x, y, z = env_to_local(rec, dx, dy, dz)
    return pdf_table(tag, rec, data, int(rec[R_TABLE]), rec[R_INTEGRAL], x, y, z)


@register_jitable
def sample_compensated(tag, rec, data, u0, u1):
    """``(x, y, z, pdf)`` of the MIS-compensated table: :meth:`pyrt.lights.environment.Environment.
    sample_compensated` (a uniform direction of density 0 where there is no such table: a constant map, or nothing
    above the mean)."""
    if tag == CONSTANT or rec[R_HAS_C] == 0.0:
        x, y, z = square_to_uniform_sphere(u0, u1)
        p = 0.0
    else:
        x, y, z, p = sample_table(tag, rec, data, int(rec[R_C_TABLE]), rec[R_C_INTEGRAL], u0, u1)
    wx, wy, wz = env_to_world(rec, x, y, z)
    return wx, wy, wz, p


@register_jitable
def pdf_compensated(tag, rec, data, dx, dy, dz):
    """Density of :func:`sample_compensated`: :meth:`pyrt.lights.environment.Environment.pdf_compensated`."""
    if tag == CONSTANT or rec[R_HAS_C] == 0.0:
        return 0.0
    x, y, z = env_to_local(rec, dx, dy, dz)
    return pdf_table(tag, rec, data, int(rec[R_C_TABLE]), rec[R_C_INTEGRAL], x, y, z)


@register_jitable
def mis_sample(tag, rec, data, u0, u1):
    """The light technique of ``strategy="mis"``, ``(x, y, z, pdf)``: :meth:`pyrt.EnvironmentLight.mis_sample`
    (the compensated table when the light compensates, else the full one)."""
    if rec[R_COMPENSATE] != 0.0:
        return sample_compensated(tag, rec, data, u0, u1)
    return sample(tag, rec, data, u0, u1)


@register_jitable
def mis_sample_uv(tag, rec, data, u0, u1):
    """:func:`mis_sample` with the sampled direction's :func:`lookup_coords` as the sampler made them, ``(wx, wy,
    wz, pdf, x, y, z, u, v)`` (the direction in the environment's frame and its lat-long ``(u, v)``, zeros for a
    constant environment): a light sample's radiance is looked up at these ``(u, v)`` instead of converting the
    direction back (``atan2``, ``acos``); the two differ by rounding only."""
    if tag == CONSTANT:
        wx, wy, wz, p = mis_sample(tag, rec, data, u0, u1)
        return wx, wy, wz, p, 0.0, 0.0, 0.0, 0.0, 0.0
    if rec[R_COMPENSATE] == 0.0:
        x, y, z, p, u, v = sample_table_uv(tag, rec, data, int(rec[R_TABLE]), rec[R_INTEGRAL], u0, u1)
    elif rec[R_HAS_C] == 0.0:
        x, y, z = square_to_uniform_sphere(u0, u1)
        p = 0.0
        u, v = latlong_dir_to_uv(x, y, z)
    else:
        x, y, z, p, u, v = sample_table_uv(tag, rec, data, int(rec[R_C_TABLE]), rec[R_C_INTEGRAL], u0, u1)
    wx, wy, wz = env_to_world(rec, x, y, z)
    return wx, wy, wz, p, x, y, z, u, v


@register_jitable
def mis_pdf(tag, rec, data, dx, dy, dz):
    """Density of :func:`mis_sample` at a world direction: :meth:`pyrt.EnvironmentLight.mis_pdf`."""
    if rec[R_COMPENSATE] != 0.0:
        return pdf_compensated(tag, rec, data, dx, dy, dz)
    return pdf(tag, rec, data, dx, dy, dz)


@register_jitable
def lookup_coords(tag, rec, dx, dy, dz):
    """``(x, y, z, u, v)``: the unit world direction ``d`` in the environment's frame and its lat-long coordinates,
    as :func:`radiance` and :func:`pdf_table` compute them (zeros for a constant environment, which needs none)."""
    if tag == CONSTANT:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    x, y, z = env_to_local(rec, dx, dy, dz)
    u, v = latlong_dir_to_uv(x, y, z)
    return x, y, z, u, v


@register_jitable
def radiance_at(tag, rec, data, dx, dy, dz, u, v):
    """:func:`radiance` of the unit world direction ``d`` whose :func:`lookup_coords` are ``(.., u, v)``: the same
    values without computing them again."""
    if tag == CONSTANT:
        return radiance(tag, rec, data, dx, dy, dz)
    s = rec[R_INTENSITY]
    r, g, b = latlong_lookup(tag, rec, data, u, v)
    return s * r, s * g, s * b


@register_jitable
def prefetch_lookup(tag, rec, data, u, v, density):
    """Prefetch (:func:`pyrt.core.unmanaged.prefetch`) the texel rows that :func:`latlong_lookup` reads at ``(u, v)``
    and, with ``density``, the table entries of :func:`pdf_table_uv` (:func:`mis_pdf`'s table); changes nothing."""
    if tag == CONSTANT:
        return
    h, w = int(rec[R_H]), int(rec[R_W])
    o = int(rec[R_IMAGE])
    ix = J.wrap_int(int(math.floor(u * w - 0.5)), w)
    iy = int(math.floor(v * h - 0.5))
    r0, r1 = min(max(iy, 0), h - 1) * w, min(max(iy + 1, 0), h - 1) * w
    U.prefetch(data, o + 3 * (r0 + ix))
    U.prefetch(data, o + 3 * (r0 + ix) + 5)
    U.prefetch(data, o + 3 * (r1 + ix))
    U.prefetch(data, o + 3 * (r1 + ix) + 5)
    if density:
        k = min(max(iy + 1, 0), h)
        lum = int(rec[R_LUM])
        U.prefetch(data, lum + min(max(k - 1, 0), h - 1) * w + ix)
        U.prefetch(data, lum + min(k, h - 1) * w + ix)
        table = int(rec[R_TABLE]) if rec[R_COMPENSATE] == 0.0 else int(rec[R_C_TABLE])
        U.prefetch(data, table + k * w + ix)


@register_jitable
def radiance_mis_pdf(tag, rec, data, dx, dy, dz):
    """``(r, g, b, pdf)``: :func:`radiance` and :func:`mis_pdf` at one unit world direction (what a BSDF sample of
    the environment light needs), the direction's lat-long coordinates computed once for both: the same values as
    the two calls."""
    x, y, z, u, v = lookup_coords(tag, rec, dx, dy, dz)
    return radiance_mis_pdf_at(tag, rec, data, dx, dy, dz, x, y, z, u, v)


@register_jitable
def radiance_mis_pdf_at(tag, rec, data, dx, dy, dz, x, y, z, u, v):
    """:func:`radiance_mis_pdf` of the unit world direction ``d`` whose :func:`lookup_coords` are ``(x, y, z, u,
    v)``."""
    if tag == CONSTANT:
        r, g, b = radiance(tag, rec, data, dx, dy, dz)
        return r, g, b, mis_pdf(tag, rec, data, dx, dy, dz)
    s = rec[R_INTENSITY]
    r, g, b = latlong_lookup(tag, rec, data, u, v)
    if rec[R_COMPENSATE] == 0.0:
        p = pdf_table_uv(tag, rec, data, int(rec[R_TABLE]), rec[R_INTEGRAL], x, y, z, u, v)
    elif rec[R_HAS_C] == 0.0:
        p = 0.0
    else:
        p = pdf_table_uv(tag, rec, data, int(rec[R_C_TABLE]), rec[R_C_INTEGRAL], x, y, z, u, v)
    return s * r, s * g, s * b, p


@register_jitable(forceinline=True)
def mis_weights(rec, pdf_light, pdf_bsdf):
    """``(w_light, w_bsdf)`` of a direction of light density ``pdf_light`` (:func:`mis_pdf`) and BSDF density
    ``pdf_bsdf``: :meth:`pyrt.EnvironmentLight.mis_weights` (the light's heuristic with its sample counts)."""
    beta, nl, nb = rec[R_BETA], rec[R_NL], rec[R_NB]
    return (power_heuristic(pdf_light, pdf_bsdf, beta, nl, nb), power_heuristic(pdf_bsdf, pdf_light, beta, nb, nl))
