"""Unshadowed irradiance of a distant environment by quadrature over a lat-long grid of cells.

Pure functions of NumPy arrays (no pyrt, no I/O, no module state). The cached object that evaluates an
environment's radiance once and remembers ``E`` per normal is :class:`pyrt.lights.irradiance.IrradianceTable`.

The integral
------------
``E(n) = int L(w) max(0, n.w) dw`` (W m^-2 per RGB channel) over the sphere of unit directions ``w``, for a
unit normal ``n``: the irradiance a surface facing ``n`` receives when nothing occludes the environment. A
Lambertian BRDF ``rho / pi`` reflects ``rho / pi * E(n)``.

The quadrature
--------------
An ``H x W`` lat-long grid of cells (the directions of :mod:`shaders.envmap`: ``theta = pi v`` from +y,
``phi = 2 pi u``, ``d = (sin phi sin theta, cos theta, -cos phi sin theta)``), cell ``(j, i)`` covering
``theta in [pi j / H, pi (j + 1) / H]``, ``phi in [2 pi i / W, 2 pi (i + 1) / W]``. Each cell carries the
radiance ``L_ji`` at its centre direction and its exact *vector* solid angle

    ``Omega_ji = int_cell w dw``   (:func:`latlong_cell_moments`, closed form, separable in rows and columns),

and ``E(n) ~ sum_ji L_ji max(0, n . Omega_ji)``. For a cell entirely above the horizon of ``n`` the cosine
factor is integrated exactly (``int_cell n.w dw = n . Omega_ji``); only the radiance is taken at the centre
(exact where ``L`` is constant over the cell, e.g. a nearest-filtered map whose texels are unions of cells; a
bilinear map is bilinear in ``(u, v)`` inside each cell when the grid is an even refinement of the map, and the
centre value is then the cell's ``(u, v)`` average: only the correlation with the ``sin theta`` / cosine weight
is left, second order in the cell size). Cells that straddle the horizon of ``n`` are approximated by
``max(0, n . Omega)``. So a constant environment ``L`` gives ``pi L`` exactly (to rounding) for ``n = +-y``
with ``H`` even (the equator is a row boundary) and within the straddling cells' error for other normals.

Rows entirely above the horizon of ``n`` are summed from per-row moments of the radiance (:func:`row_moments`:
``sum_i L_ji``, ``sum_i c_i L_ji`` for the two column factors), so ``E`` of an upward-facing plane costs O(H);
only the rows the horizon crosses are summed cell by cell (:func:`irradiance_quadrature`).
"""
import numpy as np

from .envmap import latlong_uv_to_dir


def latlong_cell_moments(height, width):
    """Vector solid angles ``int_cell w dw`` of an ``height x width`` lat-long grid, in separable form.

    Returns ``(row_y, row_s, col_x, col_z)``, float64 of shapes (H,), (H,), (W,), (W,), such that the cell
    ``(j, i)`` has ``int w dw = (col_x[i] row_s[j], row_y[j], col_z[i] row_s[j])`` (steradians times a unit
    vector). With ``theta_0, theta_1`` the row's colatitudes and ``phi_0, phi_1`` the column's longitudes:
    ``row_s = int sin^2 theta dtheta``, ``row_y = (phi_1 - phi_0) int sin theta cos theta dtheta``,
    ``col_x = cos phi_0 - cos phi_1``, ``col_z = -(sin phi_1 - sin phi_0)``. The cell's scalar solid angle,
    ``(phi_1 - phi_0)(cos theta_0 - cos theta_1)`` (:func:`shaders.envmap.latlong_texel_solid_angle`), bounds the
    length of that vector.
    """
    th = np.pi * np.arange(height + 1) / height
    ph = 2.0 * np.pi * np.arange(width + 1) / width
    dth = th[1:] - th[:-1]
    row_s = 0.5 * dth - 0.25 * (np.sin(2.0 * th[1:]) - np.sin(2.0 * th[:-1]))
    row_y = (2.0 * np.pi / width) * 0.5 * (np.sin(th[1:]) ** 2 - np.sin(th[:-1]) ** 2)
    col_x = np.cos(ph[:-1]) - np.cos(ph[1:])
    col_z = -(np.sin(ph[1:]) - np.sin(ph[:-1]))
    return row_y, row_s, col_x, col_z


def latlong_cell_centres(height, width, row_lo=0, row_hi=None):
    """Centre directions of the cells of rows ``row_lo .. row_hi - 1`` of an ``height x width`` lat-long grid,
    ``(rows, W, 3)`` float64 (the texel centres of :func:`shaders.envmap.latlong_texel_directions`)."""
    row_hi = height if row_hi is None else row_hi
    v = (np.arange(row_lo, row_hi) + 0.5) / height
    u = (np.arange(width) + 0.5) / width
    uv = np.stack(np.broadcast_arrays(u[None, :], v[:, None]), axis=-1).reshape(-1, 2)
    return latlong_uv_to_dir(uv).reshape(v.size, width, 3)


def block_average(values, row_solid_angle, sub):
    """Solid-angle weighted means over ``sub x sub`` blocks of a lat-long grid of point values.

    ``values`` (R * sub, W * sub, C) at the centres of a fine grid's rows (a block of whole cell rows),
    ``row_solid_angle`` (R * sub,) the fine cells' solid angle per row (:func:`shaders.envmap.
    latlong_texel_solid_angle`). Returns (R, W, C) float64: ``sum L dw / sum dw`` per block (``sub = 1``: the
    values as float64).
    """
    v = np.asarray(values, dtype=np.float64)
    if sub == 1:
        return v
    r, w, c = v.shape[0] // sub, v.shape[1] // sub, v.shape[2]
    dw = np.asarray(row_solid_angle, dtype=np.float64).reshape(r, sub)
    blocks = v.reshape(r, sub, w, sub, c)
    num = np.einsum("rajbc,ra->rjc", blocks, dw)
    return num / (sub * dw.sum(axis=1))[:, None, None]


def row_moments(radiance, col_x, col_z):
    """Per-row sums ``(sum_i L_ji, sum_i col_x[i] L_ji, sum_i col_z[i] L_ji)``, each (H, C) float64, of a grid of
    radiance ``(H, W, C)``: what a row entirely above a normal's horizon contributes (:func:`irradiance_quadrature`)."""
    L = np.asarray(radiance, dtype=np.float64)
    return L.sum(axis=1), np.einsum("jic,i->jc", L, col_x), np.einsum("jic,i->jc", L, col_z)


def irradiance_quadrature(radiance, moments, sums, normals):
    """``E(n) = sum_ji L_ji max(0, n . Omega_ji)`` (M, C) float64 for unit ``normals`` (M, 3).

    ``radiance`` (H, W, C) the grid's radiance at the cell centres, ``moments`` from :func:`latlong_cell_moments`,
    ``sums`` from :func:`row_moments`. Per normal: rows entirely below its horizon add nothing, rows entirely
    above add ``n_y row_y L0 + row_s (n_x Lx + n_z Lz)`` from the row sums, the rows its horizon crosses are
    summed cell by cell. Each normal is computed alone, so its value does not depend on the others in the call.
    """
    row_y, row_s, col_x, col_z = moments
    s0, sx, sz = sums
    normals = np.asarray(normals, dtype=np.float64)
    out = np.zeros((normals.shape[0], s0.shape[1]))
    for k, (nx, ny, nz) in enumerate(normals):
        a = nx * col_x + nz * col_z                # (W,): n . Omega = ny row_y + row_s a
        lo = ny * row_y + row_s * a.min()
        hi = ny * row_y + row_s * a.max()
        full = np.flatnonzero(lo >= 0.0)
        part = np.flatnonzero((hi > 0.0) & (lo < 0.0))
        e = (np.einsum("j,jc->c", ny * row_y[full], s0[full])
             + np.einsum("j,jc->c", row_s[full], nx * sx[full] + nz * sz[full]))
        if part.size:
            c = ny * row_y[part, None] + row_s[part, None] * a[None, :]
            np.maximum(c, 0.0, out=c)
            e = e + np.einsum("ji,jic->c", c, np.asarray(radiance[part], dtype=np.float64))
        out[k] = e
    return out
