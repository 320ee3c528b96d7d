"""Prototype: the environment light's light technique for packets of 16 lanes as vectorised stages, against the
render kernel's per-lane code.

What it measures: the cost of one light sample of a lat-long environment light (the compensated table's two table
searches, the bilinear cell's warps, the density, the direction and the map's bilinear radiance there) on the sky
bench scene's map (tools/_mitsuba_scenes.py: 512 x 256, float32), in CPU ns per sample, one thread, for

- ``scalar``: what the kernel runs per lane, :func:`pyrt.lights.compiled_env.mis_sample_uv` then
  :func:`~pyrt.lights.compiled_env.radiance_at` (``math.sin`` / ``math.cos`` from libm, searches from guide tables);
- ``soa``: the same numbers for 16 lanes at a time in two stages over lane arrays, each its own LLVM function with
  the ``noalias`` promise and 512-bit vectors (:func:`pyrt.core.unmanaged.noalias_args`, ``wide_vectors``): the
  searches as fixed-step binary searches, all lanes in lockstep (gathers: ``vgatherqpd``), then the warps, density,
  direction (a polynomial ``sincos``, Cody-Waite reduction and Cephes' minimax coefficients, within 3e-13 of libm's,
  since LLVM vectorises no libm call here) and the bilinear lookup (gathers) as one straight-line loop.

``--no-search`` pins every lane to one cell (the arithmetic and lookups alone, from cache); ``--sorted`` sorts the
sample numbers by their second coordinate (neighbouring lanes read neighbouring rows: the memory-latency share).
The two paths' results are compared first (radiance bit for bit, density and direction to 1e-12).

Usage: python tools/experiments/env_soa_prototype.py [--samples 65536] [--repeats 7] [--no-search] [--sorted]
"""
from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import tempfile
import time

import numba
import numpy as np

from pyrt.core import unmanaged as U
from pyrt.lights import compiled_env as CE
from pyrt.lights import compiled_tables as CT

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir))
import _mitsuba_scenes as ms  # noqa: E402  (tools/_mitsuba_scenes.py)

LANES = 16


@numba.njit(inline="always", fastmath=True)
def sincos_poly(x):
    """``(sin x, cos x)`` by Cody-Waite reduction to [-pi/4, pi/4] and minimax polynomials, branch-free (the
    quadrant chosen arithmetically) so that a loop of it vectorises."""
    j = np.floor(x * 0.6366197723675814 + 0.5)
    r = ((x - j * 1.5707963267341256) - j * 6.077100506303966e-11) - j * 2.0222662487959506e-21
    z = r * r
    s = r + r * z * (-1.6666666666666307e-01 + z * (8.3333333333224895e-03 + z * (-1.9841269834414642e-04 + z * (
        2.7557298068607406e-06 + z * (-2.5051132068021698e-08 + z * 1.5896230157221844e-10)))))
    c = 1.0 - 0.5 * z + z * z * (4.1666666666666602e-02 + z * (-1.3888888888865301e-03 + z * (
        2.4801587269650015e-05 + z * (-2.7557304623183959e-07 + z * (2.0873958177697780e-09
                                                                     + z * -1.1359647557788195e-11)))))
    q = j - 4.0 * np.floor(j * 0.25)              # the quadrant, 0..3
    odd = q - 2.0 * np.floor(q * 0.5)
    sn, cs = s + odd * (c - s), c + odd * (s - c)
    ssign = 1.0 - 2.0 * np.floor(q * 0.5)
    csign = 1.0 - 2.0 * (np.floor((q + 1.0) * 0.5) - 2.0 * np.floor((q + 1.0) * 0.25))
    return ssign * sn, csign * cs


@numba.njit(nogil=True, error_model="numpy")
def scalar(tag, rec, data, u, out):
    """The kernel's per-lane light sample and radiance for each row of ``u``: ``out`` rows (r, g, b, pdf, x, y, z)."""
    for k in range(u.shape[0]):
        x, y, z, p, _, _, _, uu, vv = CE.mis_sample_uv(tag, rec, data, u[k, 0], u[k, 1])
        r, g, b = CE.radiance_at(tag, rec, data, x, y, z, uu, vv)
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = r, g, b, p
        out[k, 4], out[k, 5], out[k, 6] = x, y, z


@numba.njit(nogil=True, fastmath=True, error_model="numpy", boundscheck=False, inline="never")
def search_stage(data, u0, u1, row, col, fu, fv, a, b, c, d, fn, o_marg, o_cond, o_lum, o, rows, w, h, top_m, top_c):
    """Stage 1: the cells of 16 lanes (fixed-step searches in lockstep), their in-cell offsets, corners and func."""
    U.wide_vectors()
    U.noalias_args()
    for lane in range(LANES):
        row[lane] = 0
        col[lane] = 0
    st = top_m
    while st >= 1:
        for lane in range(LANES):
            nk = row[lane] + st
            ok = (nk < rows) & (data[o_marg + min(nk, rows - 1)] <= u1[lane])
            row[lane] = nk if ok else row[lane]
        st >>= 1
    st = top_c
    while st >= 1:
        for lane in range(LANES):
            oc = o_cond + row[lane] * (w + 1)
            nk = col[lane] + st
            sh = float(row[lane])
            ok = (nk < w) & (data[oc + min(nk, w - 1)] + sh <= u0[lane] + sh)
            col[lane] = nk if ok else col[lane]
        st >>= 1
    for lane in range(LANES):
        lo = data[o_marg + row[lane]]
        wd = data[o_marg + row[lane] + 1] - lo
        fv[lane] = min(max((u1[lane] - lo) / wd if wd > 0.0 else 0.0, 0.0), CT.BELOW_ONE)
        oc = o_cond + row[lane] * (w + 1)
        lo = data[oc + col[lane]]
        wd = data[oc + col[lane] + 1] - lo
        fu[lane] = min(max((u0[lane] - lo) / wd if wd > 0.0 else 0.0, 0.0), CT.BELOW_ONE)
        k, i = row[lane], col[lane]
        top, bottom = min(max(k - 1, 0), h - 1) * w, min(max(k, 0), h - 1) * w
        i1 = i + 1 if i + 1 < w else 0
        a[lane], b[lane] = data[o_lum + top + i], data[o_lum + top + i1]
        c[lane], d[lane] = data[o_lum + bottom + i], data[o_lum + bottom + i1]
        fn[lane] = data[o + k * w + i]


@numba.njit(nogil=True, fastmath=True, error_model="numpy", boundscheck=False, inline="never")
def value_stage(rec, data, row, col, fu, fv, a, b, c, d, fn, out, h, w, integral, o_img, sc):
    """Stage 2: warps, density, direction and bilinear radiance of 16 lanes, one straight-line loop; ``out`` is
    (7, 16): r, g, b, pdf, x, y, z."""
    U.wide_vectors()
    U.noalias_args()
    wi, hi = int(w), int(h) - 1
    for lane in range(LANES):
        k, i = row[lane], col[lane]
        sa, sb = a[lane] + b[lane], c[lane] + d[lane]
        den = sa + math.sqrt((1.0 - fv[lane]) * sa * sa + fv[lane] * sb * sb)
        t = min(max(fv[lane] * (sa + sb) / den if den > 0.0 else fv[lane], 0.0), CT.BELOW_ONE)
        ta, tb = (1.0 - t) * a[lane] + t * c[lane], (1.0 - t) * b[lane] + t * d[lane]
        den = ta + math.sqrt((1.0 - fu[lane]) * ta * ta + fu[lane] * tb * tb)
        s = min(max(fu[lane] * (ta + tb) / den if den > 0.0 else fu[lane], 0.0), CT.BELOW_ONE)
        kf = float(k)
        v0, v1 = min(max((kf - 0.5) / h, 0.0), 1.0), min(max((kf + 0.5) / h, 0.0), 1.0)
        mean = 0.25 * (a[lane] + b[lane] + c[lane] + d[lane])
        bil = (1.0 - s) * (1.0 - t) * a[lane] + s * (1.0 - t) * b[lane] + (1.0 - s) * t * c[lane] + s * t * d[lane]
        p = fn[lane] / integral / ((h + 1) * (v1 - v0)) * (bil / mean if mean > 0.0 else 0.0)
        uu = (float(i) + 0.5 + s) / w
        uu = uu - math.floor(uu)
        vv = v0 + t * (v1 - v0)
        st, ct = sincos_poly(math.pi * vv)
        sp, cp = sincos_poly(2.0 * math.pi * uu)
        x, y, z = sp * st, ct, -cp * st
        out[3, lane] = p * CE.INV_2PI2 / st if st > 0.0 else 0.0
        out[4, lane] = x * rec[1] + y * rec[2] + z * rec[3]
        out[5, lane] = x * rec[4] + y * rec[5] + z * rec[6]
        out[6, lane] = x * rec[7] + y * rec[8] + z * rec[9]
        xx, yy = uu * w - 0.5, vv * h - 0.5
        x0, y0 = math.floor(xx), math.floor(yy)
        fx, fy = xx - x0, yy - y0
        ix0, iy0 = int(x0), int(y0)
        cx0 = ix0 + wi if ix0 < 0 else ix0
        cx1 = ix0 + 1 - wi if ix0 + 1 >= wi else ix0 + 1
        ry0, ry1 = min(max(iy0, 0), hi) * wi, min(max(iy0 + 1, 0), hi) * wi
        w0, w1, w2, w3 = (1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy
        t0, t1 = o_img + 3 * (ry0 + cx0), o_img + 3 * (ry0 + cx1)
        t2, t3 = o_img + 3 * (ry1 + cx0), o_img + 3 * (ry1 + cx1)
        for ch in range(3):
            out[ch, lane] = sc * np.float64(np.float32(w0 * data[t0 + ch] + w1 * data[t1 + ch] + w2 * data[t2 + ch]
                                                       + w3 * data[t3 + ch]))


@numba.njit(nogil=True, error_model="numpy")
def soa(rec, data, u0, u1, out, pin):
    """The two stages over blocks of 16 lanes (``pin``: every lane in cell (0, 0), no search)."""
    h, w, rows = int(rec[CE.R_H]), int(rec[CE.R_W]), int(rec[CE.R_ROWS])
    o = int(rec[CE.R_C_TABLE])
    o_cond = o + rows * w
    o_marg = o_cond + rows * (w + 1)
    top_m, top_c = 1, 1
    while top_m * 2 < rows:
        top_m *= 2
    while top_c * 2 < w:
        top_c *= 2
    if pin:
        top_m = top_c = 0
    row, col = np.zeros(LANES, np.int64), np.zeros(LANES, np.int64)
    fu, fv, fn = np.empty(LANES), np.empty(LANES), np.empty(LANES)
    a, b, c, d = np.empty(LANES), np.empty(LANES), np.empty(LANES), np.empty(LANES)
    for base in range(0, u0.shape[0], LANES):
        search_stage(data, u0[base:base + LANES], u1[base:base + LANES], row, col, fu, fv, a, b, c, d, fn, o_marg,
                     o_cond, int(rec[CE.R_LUM]), o, rows, w, h, top_m, top_c)
        value_stage(rec, data, row, col, fu, fv, a, b, c, d, fn, out[base // LANES], float(h), float(w),
                    rec[CE.R_C_INTEGRAL], int(rec[CE.R_IMAGE]), rec[CE.R_INTENSITY])


def main(argv=None):
    """Command line: check the two paths agree, then print CPU ns per light sample of each, interleaved."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--samples", type=int, default=1 << 16)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--no-search", action="store_true", help="every lane in one cell: arithmetic and lookups only")
    ap.add_argument("--sorted", action="store_true", help="sample numbers sorted by their second coordinate")
    args = ap.parse_args(argv)
    scene = ms.scene_sky(tempfile.mkdtemp(prefix="pyrt_soa_"))
    light = next(lt for lt in scene.lights if lt.environment is not None)
    tag, rec, data = CE.pack_environment(scene.environment, light)
    assert tag == CE.LATLONG_BILINEAR and rec[CE.R_COMPENSATE] == 1.0 and rec[CE.R_HAS_C] == 1.0
    n = args.samples // LANES * LANES
    u = np.random.default_rng(0).random((n, 2))
    if args.sorted:
        u = u[np.argsort(u[:, 1])]
    u0, u1 = np.ascontiguousarray(u[:, 0]), np.ascontiguousarray(u[:, 1])
    ref = np.zeros((n, 7))
    blocks = np.zeros((n // LANES, 7, LANES))
    scalar(tag, rec, data, u, ref)
    soa(rec, data, u0, u1, blocks, args.no_search)
    got = blocks.transpose(0, 2, 1).reshape(n, 7)
    if not args.no_search:
        np.testing.assert_array_equal(got[:, :3], ref[:, :3])
        np.testing.assert_allclose(got[:, 3], ref[:, 3], rtol=1e-12)
        np.testing.assert_allclose(got[:, 4:], ref[:, 4:], rtol=0, atol=1e-12)
        print("the two paths agree: radiance bit for bit, density and direction within 1e-12")
    times = {"scalar": [], "soa": []}
    load = os.getloadavg()[0]
    for _ in range(args.repeats):
        t = time.process_time()
        scalar(tag, rec, data, u, ref)
        times["scalar"].append(time.process_time() - t)
        t = time.process_time()
        soa(rec, data, u0, u1, blocks, args.no_search)
        times["soa"].append(time.process_time() - t)
    med = {k: 1e9 * statistics.median(v) / n for k, v in times.items()}
    print(f"{n} light samples, {args.repeats} interleaved repeats, load {load:.1f} -> {os.getloadavg()[0]:.1f}"
          f"{', no search' if args.no_search else ''}{', sorted' if args.sorted else ''}")
    for k, v in med.items():
        print(f"  {k:7s} {v:6.1f} ns per light sample (CPU, one thread)")
    print(f"  scalar / soa: {med['scalar'] / med['soa']:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
