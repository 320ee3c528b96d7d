"""The unshadowed irradiance ``E(n) = int L(w) max(0, n.w) dw`` of any environment, by a cached quadrature.

What it is for: the control variate of :func:`pyrt.integrators.direct.environment_estimate` adds
``albedo / pi * E(n)`` at Lambertian hits on flat faces, and only the *occluded* part of the light is left to
the samples. An error of ``E`` is a bias of that estimate, so ``E`` must be accurate, not just smooth (the 9-term
SH irradiance of the ``preview`` strategy is 2.6 % low on the test sky with a sun; this quadrature is within
~5e-4, below).

:func:`unshadowed_irradiance` (also :meth:`pyrt.lights.environment.Environment.irradiance`):

- an environment whose ``radiance_resolution`` is None (:class:`ConstantEnvironment`) has constant radiance:
  ``E = pi L`` exactly;
- any other gets an :class:`IrradianceTable`: its radiance (``_radiance_local``, the function the light samples
  see: lat-long maps bilinear-filtered by default) evaluated once on a lat-long grid of cells in the
  environment's own frame, cells an even factor >= :data:`REFINE` = 2 finer than the texels of its
  ``radiance_resolution`` along each axis and at least :data:`MIN_ROWS` = 256 rows (:func:`grid_shape`; a lat-long
  map's texels, a cube map counts as a ``2S x 4S`` lat-long map, an ``S x S`` light probe as ``S/2 x S``), and
  ``E`` per normal by the kernel :func:`shaders.irradiance.irradiance_quadrature` (exact cosine moments per cell,
  the radiance at the cell centre). Grids are at most :data:`MAX_ROWS` x 2 :data:`MAX_ROWS` cells; a map with more
  than ``MAX_ROWS / REFINE`` rows is sampled once per texel and averaged over blocks of texels (solid-angle
  weighted). ``intensity`` and ``rotate`` are applied per query (``E_world(n) = intensity E_env(R^T n)``), so they
  can change freely; the grid is rebuilt when another public attribute (the image array by identity, the filter)
  changes. Texels edited in place are not noticed (as by the importance table): assign a new array.

The value of each normal (environment frame, before ``intensity``) is kept in the table (:data:`MAX_CACHED`
normals); it depends only on the normal and the grid, never on which normals were asked together or before, so
renders stay independent of the worker count.

Measured quadrature error (tests/test_env_control_variate.py; relative, per channel, worst of ~200 normals):

- constant radiance: ``pi L`` exactly for normals +-y; 1.4e-5 at 256 x 512 cells, 1.1e-3 at 32 x 64 (second
  order in the cell size: the horizon-straddling cells);
- a 128 x 64 sky with a 3 degree sun (default grid 256 x 512): 1.1e-4 from a 2x finer grid, 1.2e-4 from a 4x
  finer one (7.7e-5 for normals above the horizon); halving the grid changes it several times more;
- the 512 x 256 sky of ``tools/_mitsuba_scenes.py`` ``scene_sky`` (default grid 512 x 1024): 3.4e-5 from 2x finer,
  4.1e-5 from 4x finer (3.0e-5 above the horizon, 7.9e-6 for +y);
- every registered environment's example against a brute-force midpoint sum over 512 x 1024 or 1024 x 2048
  texels: <= 4.5e-4, the largest for normals whose horizon cuts the sun.

So ``E`` is within ~5e-4 (the bound the tests hold it to: 1e-3), a bias of the variate's estimate far below its
noise at any practical sample count (relMSE ~1e-4 means ~1e-2 relative per pixel). Cost (2 shared cores, load
~2): the 512 x 256 sky's grid 0.11 s, ``E`` of +y 0.05 ms (rows from the row sums alone), of a tilted normal
~3 ms (the rows its horizon crosses summed cell by cell); a 128 x 64 map 0.03 s and ~0.8 ms.
"""
from __future__ import annotations

import threading
import weakref

import numpy as np

from pyrt.shaders import irradiance as Q
from pyrt.shaders.envmap import latlong_texel_solid_angle

#: quadrature cells per map texel along each axis (even: the texel centres and edges of a lat-long map are cell
#: boundaries, so a bilinear map is bilinear inside every cell and a nearest one constant)
REFINE = 2
#: at least this many rows of cells for small maps: the error is second order in the cell size, not in the texel
#: size (a 64 x 32 sky with a 3 degree sun: <= 4.8e-4 relative at 256 rows, 7.9e-3 at 64)
MIN_ROWS = 256
#: at most this many rows (and twice as many columns) of cells: 512 x 1024 cells, 12.6 MB of float64 radiance
MAX_ROWS = 512
#: radiance lookups per block while the grid is built (bounds the temporary memory)
BLOCK_LOOKUPS = 1 << 18
#: normals whose E a table keeps (beyond: computed per call, not stored)
MAX_CACHED = 1 << 16
#: attributes applied at query time or irrelevant to the radiance: they do not key the grid
QUERY_TIME = frozenset({"intensity", "rotation", "hide_background", "background", "name"})

_TABLES = weakref.WeakKeyDictionary()    # environment -> IrradianceTable
_BUILD = threading.Lock()                # one build at a time (worker threads of one render share the table)


def source_key(env):
    """What an environment's quadrature grid depends on: its public attributes but :data:`QUERY_TIME`, as a sorted
    tuple of ``(name, value)`` with arrays by identity."""
    return tuple(sorted((k, ("array", id(v)) if isinstance(v, np.ndarray) else v) for k, v in vars(env).items()
                        if not k.startswith("_") and k not in QUERY_TIME))


def grid_shape(resolution):
    """``(cell rows, cell columns, sub)`` of the quadrature grid for a map of ``resolution`` (H, W) texels.

    Maps of at most ``MAX_ROWS / REFINE`` rows: cells an even factor >= :data:`REFINE` finer than the texels,
    the smallest giving at least :data:`MIN_ROWS` rows (and at most :data:`MAX_ROWS`), one radiance sample per
    cell (``sub = 1``). Larger maps: one sample per texel, averaged over ``sub x sub`` blocks so that the grid has
    at most :data:`MAX_ROWS` rows.
    """
    h, w = int(resolution[0]), int(resolution[1])
    if REFINE * h <= MAX_ROWS:
        refine = max(REFINE, 2 * -(-MIN_ROWS // (2 * h)))
        while refine * h > MAX_ROWS:
            refine -= 2
        return refine * h, refine * w, 1
    sub = -(-h // MAX_ROWS)
    return -(-h // sub), -(-w // sub), sub


class IrradianceTable:
    """The radiance of one environment on a lat-long grid of cells, and ``E`` per normal (environment frame).

    Parameters
    ----------
    radiance_local : callable
        ``(N, 3) directions -> (N, 3) radiance`` in the environment's frame, without ``intensity``.
    resolution : (H, W)
        The lat-long texel grid that resolves that radiance (:func:`grid_shape` derives the cells from it).
    key : tuple
        :func:`source_key` of the environment when the grid was built.
    cells : (H, W), optional
        Cells of the grid, one radiance sample each, instead of :func:`grid_shape`'s (accuracy studies).

    Attributes: ``radiance`` (H, W, 3) float64 (cell averages), ``moments`` and ``sums`` (the kernel's
    precomputations), ``cells`` (H, W), ``sub`` (radiance samples per cell along each axis).
    """

    def __init__(self, radiance_local, resolution, key=(), cells=None):
        ch, cw, sub = grid_shape(resolution) if cells is None else (int(cells[0]), int(cells[1]), 1)
        ph, pw = ch * sub, cw * sub
        dw = latlong_texel_solid_angle(ph, pw)
        grid = np.empty((ch, cw, 3))
        step = max(1, BLOCK_LOOKUPS // (pw * sub))     # cell rows per block
        for r0 in range(0, ch, step):
            r1 = min(ch, r0 + step)
            d = Q.latlong_cell_centres(ph, pw, r0 * sub, r1 * sub).reshape(-1, 3)
            L = np.asarray(radiance_local(d), dtype=np.float64).reshape((r1 - r0) * sub, pw, 3)
            grid[r0:r1] = Q.block_average(L, dw[r0 * sub:r1 * sub], sub)
        self.key = key
        self.cells, self.sub = (ch, cw), sub
        self.radiance = grid
        self.moments = Q.latlong_cell_moments(ch, cw)
        self.sums = Q.row_moments(grid, self.moments[2], self.moments[3])
        self._values = {}

    def irradiance(self, normals):
        """``E`` (N, 3) float64 at unit normals (N, 3) in the environment's frame (without ``intensity``): each
        distinct normal computed once (:func:`shaders.irradiance.irradiance_quadrature`) and kept."""
        normals = np.ascontiguousarray(normals, dtype=np.float64)
        out = np.empty((normals.shape[0], 3))
        keys = [row.tobytes() for row in normals]
        missing = [i for i, k in enumerate(keys) if k not in self._values]
        if missing:
            new = Q.irradiance_quadrature(self.radiance, self.moments, self.sums, normals[missing])
            for i, e in zip(missing, new):
                if len(self._values) < MAX_CACHED:
                    self._values[keys[i]] = e
                out[i] = e
        for i, k in enumerate(keys):
            e = self._values.get(k)
            if e is not None:
                out[i] = e
        return out

    @property
    def n_cached(self):
        """How many normals' values the table keeps."""
        return len(self._values)


def irradiance_table(env):
    """The :class:`IrradianceTable` of ``env`` (an environment with a ``radiance_resolution``), built on first use
    and again when its :func:`source_key` changed; the grid keeps a reference to the arrays it was keyed on."""
    key = source_key(env)
    table = _TABLES.get(env)
    if table is None or table.key != key:
        with _BUILD:
            table = _TABLES.get(env)
            if table is None or table.key != key:
                table = IrradianceTable(env._radiance_local, env.radiance_resolution, key)
                table.refs = [v for v in vars(env).values() if isinstance(v, np.ndarray)]   # ids stay unique
                _TABLES[env] = table
    return table


def unshadowed_irradiance(env, normals):
    """``E(n) = int L(w) max(0, n.w) dw`` (N, 3) float64, W m^-2 per channel, at unit world ``normals`` (N, 3) of
    the environment ``env`` (intensity and rotation applied): ``pi L`` exactly for constant radiance
    (``env.radiance_resolution`` None), else the cached quadrature (module docstring; error measured there)."""
    normals = np.asarray(normals, dtype=np.float64)
    if env.radiance_resolution is None:
        return np.pi * env.radiance(normals)
    return env.intensity * irradiance_table(env).irradiance(env.to_local(normals))
