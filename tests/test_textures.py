"""Tests for shaders/textures.py and the pyrt.textures package (no renderer needed).

Ground truths: exact texel values for wrap modes and UV orientation; exact box averages for MIP
levels; the analytic pixel footprint of a pinhole camera on a tilted plane for level selection;
a 256-spp supersampled bilinear reference of an analytically ray-traced grazing plane for the
filter-quality bounds.
"""
import os

import numpy as np
import pytest

from pyrt.geometry import SurfaceBatch
from pyrt.shaders import color
from pyrt.shaders import ewa as E
from pyrt.shaders import textures as K
from pyrt import textures as T
from pyrt.textures.image import ChannelTexture


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


#: what ``import numba`` loads of SciPy (its version check imports the bare package, ~20 ms): allowed; every SciPy
#: subpackage (spatial, sparse, ndimage, ... ~0.3 s) is not
_NUMBA_SCIPY = ("scipy", "scipy.__config__", "scipy.version", "scipy._distributor_init", "scipy._distributor_init_local",
                "scipy._lib", "scipy._lib._ccallback", "scipy._lib._ccallback_c", "scipy._lib._pep440",
                "scipy._lib._testutils", "scipy._cyutility")

def ctx_of(uv, duvdx=None, duvdy=None, **kw):
    """A :class:`pyrt.geometry.SurfaceBatch` at ``uv`` (hit points at the origin unless ``p`` is given)."""
    uv = np.asarray(uv, dtype=np.float64)
    n = len(uv)
    z = np.zeros((n, 2))
    kw.setdefault("p", np.zeros((n, 3)))
    return SurfaceBatch(uv=uv, duvdx=z if duvdx is None else duvdx, duvdy=z if duvdy is None else duvdy, **kw)


# ----------------------------------------------------------------------------- wrap / orientation

def test_wrap_index_modes():
    i = np.arange(-5, 9)
    assert K.wrap_index(i, 4, "repeat").tolist() == [3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0]
    assert K.wrap_index(i, 4, "clamp").tolist() == [0, 0, 0, 0, 0, 0, 1, 2, 3, 3, 3, 3, 3, 3]
    assert K.wrap_index(i, 4, "mirror").tolist() == [3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0, 0]
    assert K.wrap_index(np.array([-1, 0, 1, 2]), 1, "mirror").tolist() == [0, 0, 0, 0]
    with pytest.raises(ValueError, match="wrap"):
        K.wrap_index(i, 4, "border")
    with pytest.raises(ValueError, match="wrap"):
        K.check_wrap(("repeat", "nope"))


def test_uv_origin_is_bottom_left_and_v_points_up():
    img = np.zeros((2, 2, 3), np.float32)
    img[0, 0] = (1, 0, 0)  # top-left
    img[0, 1] = (0, 1, 0)  # top-right
    img[1, 0] = (0, 0, 1)  # bottom-left
    uv = np.array([[0.25, 0.25], [0.25, 0.75], [0.75, 0.75]])
    got = K.lookup_nearest(img, uv)
    np.testing.assert_array_equal(got, [img[1, 0], img[0, 0], img[0, 1]])


def test_wrap_modes_on_known_uvs():
    # 1 x 4 image with texel values 0..3; texel k covers u in [k/4, (k+1)/4).
    img = np.arange(4, dtype=np.float64).reshape(1, 4, 1)
    u = np.array([1.125, -0.125, 2.375, 1.875, -1.625])
    uv = np.stack([u, np.full_like(u, 0.5)], axis=1)
    look = lambda w: K.lookup_nearest(img, uv, w)[:, 0].tolist()  # noqa: E731
    assert look("repeat") == [0, 3, 1, 3, 1]
    assert look("clamp") == [3, 0, 3, 3, 0]
    # mirror: period 2; [1, 2) and [-1, 0) are the reversed image.
    assert look("mirror") == [3, 0, 1, 0, 1]  # -1.625 = 0.375 - 2: an unmirrored tile
    # Per-axis wrap: u repeats, v clamps.
    img2 = np.arange(6, dtype=np.float64).reshape(2, 3, 1)  # rows: top 0 1 2, bottom 3 4 5
    uv2 = np.array([[1.1, 5.0], [-0.1, -3.0]])
    assert K.lookup_nearest(img2, uv2, ("repeat", "clamp"))[:, 0].tolist() == [0, 5]


def test_bilinear_wraps_across_the_seam():
    img = np.array([[[0.0], [10.0]]])  # 1 x 2
    uv = np.array([[0.0, 0.5], [1.0, 0.5]])  # exactly on the seam between texel 1 and texel 0
    np.testing.assert_allclose(K.lookup_bilinear(img, uv, "repeat")[:, 0], [5.0, 5.0])
    np.testing.assert_allclose(K.lookup_bilinear(img, uv, "clamp")[:, 0], [0.0, 10.0])


def test_bilinear_and_bicubic_interpolate_texel_centres(rng):
    img = rng.random((7, 9, 3))
    rows, cols = np.mgrid[0:7, 0:9]
    uv = np.stack([(cols.ravel() + 0.5) / 9, 1 - (rows.ravel() + 0.5) / 7], axis=1)
    want = img[rows.ravel(), cols.ravel()]
    np.testing.assert_allclose(K.lookup_bilinear(img, uv), want, atol=1e-12)
    np.testing.assert_allclose(K.lookup_bicubic(img, uv), want, atol=1e-12)


def test_bilinear_and_bicubic_reproduce_linear_ramps(rng):
    # Both kernels reproduce linear functions exactly (Catmull-Rom has linear precision).
    h, w = 16, 20
    rows, cols = np.mgrid[0:h, 0:w]
    img = (0.3 * cols + 0.7 * rows + 1.0)[..., None]
    uv = rng.uniform([2.5 / w, 2.5 / h], [1 - 2.5 / w, 1 - 2.5 / h], (500, 2))
    x, y = K.uv_to_texel(uv, img.shape)
    want = 0.3 * x + 0.7 * y + 1.0
    np.testing.assert_allclose(K.lookup_bilinear(img, uv, "clamp")[:, 0], want, atol=1e-12)
    np.testing.assert_allclose(K.lookup_bicubic(img, uv, "clamp")[:, 0], want, atol=1e-12)


def test_bicubic_does_not_overshoot():
    img = np.zeros((1, 8, 1))
    img[0, 4:] = 1.0  # a step: Catmull-Rom rings to -0.07 / 1.07 without the clamp
    uv = np.stack([np.linspace(0, 1, 200), np.full(200, 0.5)], axis=1)
    v = K.lookup_bicubic(img, uv, "clamp")
    assert v.min() >= 0.0 and v.max() <= 1.0


def test_lookups_preserve_float32(rng):
    img = rng.random((8, 8, 3)).astype(np.float32)
    uv = rng.random((50, 2))
    d = np.full((50, 2), 0.3)
    for fn in (K.lookup_nearest, K.lookup_bilinear, K.lookup_bicubic):
        assert fn(img, uv).dtype == np.float32
    pyr = [K.build_mip_level(img, l) for l in range(K.n_mip_levels(img.shape))]
    assert K.lookup_trilinear(pyr, uv, d, d).dtype == np.float32
    assert E.lookup_ewa(pyr, uv, d, d * [1, -0.1]).dtype == np.float32


# ----------------------------------------------------------------------------- UV transform

def test_uv_transform_scale_rotation_offset():
    uv = np.array([[0.25, 0.0]])
    d = np.array([[0.1, 0.0]])
    out, dx, _ = K.transform_uv(uv, d, None, scale=(2.0, 3.0), offset=(0.5, 0.25), rotation=np.pi / 2)
    # scale -> (0.5, 0); rotate 90 deg CCW -> (0, 0.5); offset -> (0.5, 0.75)
    np.testing.assert_allclose(out, [[0.5, 0.75]], atol=1e-15)
    np.testing.assert_allclose(dx, [[0.0, 0.2]], atol=1e-15)


def test_image_texture_uv_transform_tiles():
    img = np.arange(4, dtype=np.float64).reshape(1, 4, 1)
    tex = T.ImageTexture(img, filter="nearest", scale=(2.0, 1.0))
    got = tex.evaluate(ctx_of([[0.1, 0.5], [0.6, 0.5]]))
    np.testing.assert_array_equal(got[:, 0], [0, 0])  # u' = 0.2, 1.2 -> texel 0 both
    tex = T.ImageTexture(img, filter="nearest", offset=(0.25, 0.0))
    np.testing.assert_array_equal(tex.evaluate(ctx_of([[0.1, 0.5]]))[:, 0], [1])


# ----------------------------------------------------------------------------- MIP pyramid

@pytest.mark.parametrize("shape", [(64, 64), (37, 53), (1, 17), (5, 1), (100, 3)])
def test_mip_levels_preserve_the_mean_and_shapes(shape, rng):
    img = rng.random(shape + (2,))
    n = K.n_mip_levels(img.shape)
    assert n == 1 + int(np.floor(np.log2(max(shape))))
    for l in range(n):
        lev = K.build_mip_level(img, l)
        assert lev.shape[:2] == (max(1, shape[0] >> l), max(1, shape[1] >> l))
        np.testing.assert_allclose(lev.mean(axis=(0, 1)), img.mean(axis=(0, 1)), rtol=1e-12)
    assert K.build_mip_level(img, n - 1).shape[:2] in ((1, 1), (1, max(1, shape[1] >> (n - 1))),
                                                       (max(1, shape[0] >> (n - 1)), 1))


def test_mip_level_power_of_two_is_the_2x2_box(rng):
    img = rng.random((16, 8, 3))
    lev1 = K.build_mip_level(img, 1)
    box = img.reshape(8, 2, 4, 2, 3).mean(axis=(1, 3))
    np.testing.assert_allclose(lev1, box, atol=1e-14)
    lev2 = K.build_mip_level(img, 2)
    np.testing.assert_allclose(lev2, lev1.reshape(4, 2, 2, 2, 3).mean(axis=(1, 3)), atol=1e-14)


def test_mip_level_npot_is_the_exact_area_average():
    # 3 texels -> 1: plain mean; 5 -> 2: cells [0, 2.5) and [2.5, 5).
    img = np.array([[[1.0], [2.0], [6.0], [3.0], [5.0]]])
    lev = K.build_mip_level(img, 1)
    np.testing.assert_allclose(lev[0, :, 0], [(1 + 2 + 0.5 * 6) / 2.5, (0.5 * 6 + 3 + 5) / 2.5])
    np.testing.assert_allclose(K.build_mip_level(img, 2)[0, :, 0], [17 / 5])


def test_mip_level_bounds():
    with pytest.raises(ValueError, match="level"):
        K.build_mip_level(np.zeros((4, 4, 1)), 3)


# ----------------------------------------------------------------------------- level selection

def pinhole_plane_footprint(dist, theta, vfov_deg, height_px, tile):
    """Rays through the image centre +- half a pixel in x / y hitting a plane at distance ``dist``
    along the optical axis, tilted by ``theta`` about the camera x axis; uv = plane coords / tile.

    Returns the uv of the centre hit and the central uv differences over one pixel step (exact
    ray-plane intersections, no linearisation; the error to the derivative is second order).
    """
    f = 1.0 / np.tan(np.deg2rad(vfov_deg) / 2)  # image-plane distance for half-height 1
    px = 2.0 / height_px  # pixel step on the image plane
    n = np.array([0.0, np.sin(theta), np.cos(theta)])  # plane normal (camera looks along -z)
    e1 = np.array([1.0, 0.0, 0.0])
    e2 = np.cross(n, e1)
    p0 = np.array([0.0, 0.0, -dist])

    def hit(sx, sy):
        d = np.array([sx, sy, -f])
        t = np.dot(p0, n) / np.dot(d, n)
        q = t * d - p0
        return np.array([np.dot(q, e1), np.dot(q, e2)]) / tile

    c = hit(0.0, 0.0)
    return c, hit(px / 2, 0.0) - hit(-px / 2, 0.0), hit(0.0, px / 2) - hit(0.0, -px / 2), f, px


@pytest.mark.parametrize("theta_deg", [0.0, 45.0, 75.0])
@pytest.mark.parametrize("dist", [2.0, 10.0, 50.0])
def test_mip_level_matches_analytic_plane_footprint(dist, theta_deg, rng):
    theta = np.deg2rad(theta_deg)
    vfov, height_px, tile, tex_res = 40.0, 512, 1.0, (256, 256, 3)
    _, dx, dy, f, px = pinhole_plane_footprint(dist, theta, vfov, height_px, tile)
    # Analytic: a pixel subtends px / f radians at the centre; on the plane that is dist * px / f
    # across x and dist * px / (f cos theta) along the tilt (the y step stretches).
    along_y = dist * px / (f * np.cos(theta)) / tile * tex_res[0]
    lam_expected = np.log2(along_y)
    lam = K.mip_level_isotropic(dx[None], dy[None], tex_res)[0]
    # Central difference vs derivative: relative error ~ (px/f tan(theta))^2 < 1e-4 here.
    assert abs(lam - lam_expected) < 1e-3
    # EWA: minor half-axis = 1.5 / 2 * dist * px / f (across), major stretched by 1 / cos(theta).
    major, minor, lam_e = E.ewa_axes(dx[None], dy[None], tex_res, 1.5, 8.0)
    across = 0.75 * dist * px / f / tile * tex_res[1]
    assert abs(lam_e[0] - np.log2(across)) < 1e-3
    ratio = np.linalg.norm(major) / np.linalg.norm(minor)
    assert abs(ratio * np.cos(theta) - 1) < 1e-3


def test_ewa_axes_clamp_anisotropy():
    dx = np.array([[1.0, 0.0], [0.5, 0.0], [0.0, 0.0]])
    dy = np.array([[0.0, 0.001], [0.0, 0.0], [0.0, 0.0]])
    major, minor, lam = E.ewa_axes(dx, dy, (100, 100), footprint_scale=2.0, max_anisotropy=8.0)
    np.testing.assert_allclose(np.linalg.norm(major, axis=1), [100, 50, 0])
    np.testing.assert_allclose(np.linalg.norm(minor, axis=1), [12.5, 6.25, 0])
    np.testing.assert_allclose(lam[:2], np.log2([12.5, 6.25]))
    assert lam[2] == -np.inf
    assert abs(np.dot(major[1], minor[1])) < 1e-12  # degenerate minor -> perpendicular


def test_trilinear_levels_split():
    l0, l1, w1 = K.trilinear_levels(np.array([-np.inf, -1.0, 0.0, 1.25, 2.5, 3.0, 9.0]), 4)
    assert l0.tolist() == [0, 0, 0, 1, 2, 3, 3]
    assert l1.tolist() == [1, 1, 1, 2, 3, 3, 3]
    np.testing.assert_allclose(w1, [0, 0, 0, 0.25, 0.5, 0, 0])
    assert K.levels_needed(l0, l1, w1) == [0, 1, 2, 3]
    assert K.levels_needed(l0[:3], l1[:3], w1[:3]) == [0]


# ----------------------------------------------------------------------------- every filter

@pytest.mark.parametrize("filt", T.FILTERS)
@pytest.mark.parametrize("wrap", ["repeat", "mirror", "clamp"])
def test_constant_texture_same_through_every_filter(filt, wrap, rng):
    value = np.array([0.2, 0.5, 0.9], np.float32)
    img = np.broadcast_to(value, (37, 53, 3)).copy()
    n = 2000
    uv = rng.uniform(-3, 3, (n, 2))
    dx = rng.normal(scale=0.2, size=(n, 2)) * rng.choice([0, 1e-3, 1, 10], size=(n, 1))
    dy = rng.normal(scale=0.2, size=(n, 2)) * rng.choice([0, 1e-3, 1, 10], size=(n, 1))
    tex = T.ImageTexture(img, filter=filt, wrap=wrap, rotation_deg=30, scale=(2, 0.5))
    got = tex.evaluate(ctx_of(uv, dx, dy))
    assert got.dtype == np.float64 and got.shape == (n, 3)
    np.testing.assert_allclose(got, np.broadcast_to(value, (n, 3)), rtol=1e-6)


def test_trilinear_reproduces_linear_ramps_at_every_level(rng):
    # Box levels of a linear ramp are the ramp sampled at the coarse texel centres, so trilinear
    # returns the ramp exactly away from the borders (any level, any blend).
    h = w = 256
    rows, cols = np.mgrid[0:h, 0:w]
    img = ((cols + 0.5) / w * 2.0 + (rows + 0.5) / h * 3.0)[..., None]
    tex = T.ImageTexture(img, filter="trilinear", wrap="clamp")
    n = 300
    uv = rng.uniform(0.3, 0.7, (n, 2))
    s = 10 ** rng.uniform(-3, -1.3, (n, 1))
    got = tex.lookup(uv, s * [1.0, 0.0], s * [0.0, 1.0])[:, 0]
    np.testing.assert_allclose(got, uv[:, 0] * 2.0 + (1 - uv[:, 1]) * 3.0, atol=1e-5)


# ----------------------------------------------------------------------------- lazy pyramid

def test_no_mip_level_built_when_only_magnified(rng):
    tex = T.ImageTexture(rng.random((64, 64, 3)), filter="trilinear")
    uv = rng.random((100, 2))
    tex.lookup(uv, np.full((100, 2), 0.5 / 64), np.zeros((100, 2)))  # half a texel: magnified
    tex.lookup(uv)  # no footprint at all
    assert tex.mip_levels_built == []


@pytest.mark.parametrize("filt", ["trilinear", "anisotropic"])
def test_only_read_mip_levels_are_built(filt, rng):
    tex = T.ImageTexture(rng.random((64, 64, 1)), filter=filt)
    uv = rng.random((10, 2))
    # Isotropic footprint of exactly 4 texels (times the filter's scale): level 2 (trilinear) only.
    fs = tex.footprint_scale
    d = np.full((10, 2), 0.0)
    d[:, 0] = 4.0 / 64 / fs * (2.0 if filt == "anisotropic" else 1.0)
    dy = d[:, ::-1].copy()
    tex.lookup(uv, d, dy)
    assert tex.mip_levels_built == [2]
    # A footprint at level 3.5 reads levels 3 and 4 only.
    tex.lookup(uv, d * 2 ** 1.5, dy * 2 ** 1.5)
    assert tex.mip_levels_built == [2, 3, 4]


# ----------------------------------------------------------------------------- filter quality

def _plane_uv(width, height, sx, sy, cam_h=1.0, pitch_deg=20.0, vfov_deg=30.0, tile=4.0):
    """Exact uv on the ground plane y = 0 seen by a pinhole camera pitched down (grazing view).

    uv = (x, -z) / tile. With these parameters every pixel hits the plane (top row 5 degrees
    below the horizon, ~11 units away; bottom row 2.1 units away).
    """
    tan = np.tan(np.deg2rad(vfov_deg) / 2)
    px = (2 * sx / width - 1) * tan * width / height
    py = (1 - 2 * sy / height) * tan
    c, s = np.cos(np.deg2rad(pitch_deg)), np.sin(np.deg2rad(pitch_deg))
    d = (np.array([0, -s, -c]) + px[..., None] * np.array([1.0, 0, 0]) + py[..., None] * np.array([0, c, -s]))
    t = -cam_h / d[..., 1]
    return np.stack([t * d[..., 0] / tile, -t * d[..., 2] / tile], axis=-1)


def _render_plane(tex, width, height, spp_side):
    """Average of ``spp_side^2`` stratified lookups per pixel; footprints are the exact central
    differences over one pixel step (what ray differentials linearise)."""
    jj, ii = np.mgrid[0:height, 0:width]
    ii, jj = ii.ravel().astype(float), jj.ravel().astype(float)
    acc = 0.0
    for a in range(spp_side):
        for b in range(spp_side):
            sx, sy = ii + (a + 0.5) / spp_side, jj + (b + 0.5) / spp_side
            dx = _plane_uv(width, height, sx + 0.5, sy) - _plane_uv(width, height, sx - 0.5, sy)
            dy = _plane_uv(width, height, sx, sy + 0.5) - _plane_uv(width, height, sx, sy - 0.5)
            acc = acc + tex.lookup(_plane_uv(width, height, sx, sy), dx, dy)
    return acc / spp_side ** 2


@pytest.fixture(scope="module")
def grazing_results():
    rng = np.random.default_rng(7)
    yy, xx = np.mgrid[0:128, 0:128]
    images = {"checker": (((xx // 8) + (yy // 8)) % 2).astype(np.float32)[..., None],
              "noise": rng.random((128, 128, 1)).astype(np.float32)}
    out = {}
    for name, img in images.items():
        ref = _render_plane(T.ImageTexture(img, filter="bilinear"), 64, 48, 16)
        out[name] = {f: float(np.sqrt(np.mean((_render_plane(T.ImageTexture(img, filter=f), 64, 48, 1) - ref) ** 2)))
                     for f in ("nearest", "bilinear", "trilinear", "anisotropic")}
    return out


@pytest.mark.parametrize("name", ["checker", "noise"])
def test_trilinear_error_bound_and_far_below_nearest(grazing_results, name):
    # Measured (64x48 px, 128^2 texture, 256-spp bilinear reference): checker nearest 0.295,
    # trilinear 0.077; noise nearest 0.243, trilinear 0.064. Bound with ~30% margin.
    r = grazing_results[name]
    assert r["trilinear"] < 0.10
    assert r["trilinear"] < 0.35 * r["nearest"]
    assert r["trilinear"] < 0.6 * r["bilinear"]


@pytest.mark.parametrize("name", ["checker", "noise"])
def test_anisotropic_beats_trilinear_at_grazing_angles(grazing_results, name):
    # Measured: checker 0.030 vs 0.077, noise 0.017 vs 0.064.
    r = grazing_results[name]
    assert r["anisotropic"] < 0.6 * r["trilinear"]


# ----------------------------------------------------------------------------- loading

def test_srgb_decode_encode_round_trip():
    x8 = np.arange(256) / 255.0
    np.testing.assert_allclose(color.srgb_encode(color.srgb_decode(x8)), x8, atol=1e-12)
    x = np.linspace(0, 1, 1001)
    np.testing.assert_allclose(color.srgb_decode(color.srgb_encode(x)), x, atol=1e-12)
    # Spot values (IEC 61966-2-1): 0.5 encoded -> 0.21404 linear; 0.04045 is the knee.
    np.testing.assert_allclose(color.srgb_decode(np.array([0.5, 0.04045])), [0.214041, 0.04045 / 12.92], rtol=1e-5)


def test_png_8bit_colour_is_linearised_and_data_is_not(tmp_path, rng):
    from skimage import io as skio

    img8 = rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)
    path = tmp_path / "c.png"
    skio.imsave(path, img8, check_contrast=False)
    tex = T.ImageTexture(path)
    assert tex.srgb
    np.testing.assert_allclose(tex.image, color.srgb_decode(img8 / 255.0), atol=1e-6)
    data = T.ImageTexture(path, srgb=False)
    np.testing.assert_allclose(data.image, img8 / 255.0, atol=1e-7)


def _write_png16(path, img):
    """Minimal 16-bit PNG writer (filter 0, zlib): Pillow cannot write 16-bit colour PNGs."""
    import struct
    import zlib

    h, w, c = img.shape
    raw = b"".join(b"\x00" + img[r].astype(">u2").tobytes() for r in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", w, h, 16, {1: 0, 2: 4, 3: 2, 4: 6}[c], 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


@pytest.mark.parametrize("c", [1, 2, 3, 4])
def test_png_16bit_exact(tmp_path, rng, c):
    img16 = rng.integers(0, 65536, (4, 6, c), dtype=np.uint16)
    _write_png16(tmp_path / "a.png", img16)
    tex = T.ImageTexture(tmp_path / "a.png", srgb=False)
    keep = {1: 1, 2: 1, 3: 3, 4: 3}[c]  # alpha dropped
    assert tex.channels == keep
    np.testing.assert_allclose(tex.image, img16[..., :keep] / 65535.0, atol=1e-7)
    tex = T.ImageTexture(tmp_path / "a.png")  # integer image: sRGB by default
    np.testing.assert_allclose(tex.image, color.srgb_decode(img16[..., :keep] / 65535.0), atol=1e-6)


def test_png_grey_8bit(tmp_path, rng):
    from skimage import io as skio

    grey = rng.integers(0, 256, (4, 6), dtype=np.uint8)
    skio.imsave(tmp_path / "g.png", grey, check_contrast=False)
    tex = T.ImageTexture(tmp_path / "g.png", srgb=False)
    assert tex.channels == 1
    np.testing.assert_allclose(tex.image[..., 0], grey / 255.0, atol=1e-7)


def test_jpeg_loads(tmp_path):
    from skimage import io as skio

    img = np.full((8, 8, 3), 128, np.uint8)
    skio.imsave(tmp_path / "j.jpg", img, check_contrast=False)
    tex = T.ImageTexture(tmp_path / "j.jpg")
    np.testing.assert_allclose(tex.image, color.srgb_decode(np.full((8, 8, 3), 128 / 255.0)), atol=2e-3)


def _write_exr(path, img):
    import OpenEXR

    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                      {"RGB": np.ascontiguousarray(img, np.float32)}) as f:
        f.write(str(path))


def test_exr_is_linear_float(tmp_path, rng):
    img = rng.uniform(0, 20, (6, 5, 3)).astype(np.float32)
    _write_exr(tmp_path / "e.exr", img)
    tex = T.ImageTexture(tmp_path / "e.exr")
    assert not tex.srgb
    np.testing.assert_array_equal(tex.image, img)


def _write_exr_channels(path, channels):
    import OpenEXR

    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                      {k: np.ascontiguousarray(v) for k, v in channels.items()}) as f:
        f.write(str(path))


def test_exr_channel_layouts_load_as_stored(tmp_path, rng):
    """pyrt.read_exr(layout="stored") is the texture loader's EXR reader: RGBA, Y, one channel, one layer,
    mixed pixel types; alpha is dropped by the texture, not the reader."""
    from pyrt.core.image_io import read_exr

    r, g, b, a = (rng.uniform(0, 4, (3, 5)).astype(np.float32) for _ in range(4))
    _write_exr_channels(tmp_path / "rgba.exr", {"R": r, "G": g, "B": b, "A": a.astype(np.float16)})
    np.testing.assert_array_equal(read_exr(tmp_path / "rgba.exr", layout="stored"),
                                  np.stack([r, g, b, a.astype(np.float16).astype(np.float32)], axis=-1))
    np.testing.assert_array_equal(T.ImageTexture(tmp_path / "rgba.exr").image, np.stack([r, g, b], axis=-1))
    np.testing.assert_array_equal(read_exr(tmp_path / "rgba.exr"), np.stack([r, g, b], axis=-1))
    _write_exr_channels(tmp_path / "ya.exr", {"Y": r, "A": a})
    np.testing.assert_array_equal(T.ImageTexture(tmp_path / "ya.exr").image[..., 0], r)
    _write_exr_channels(tmp_path / "z.exr", {"Z": g})
    np.testing.assert_array_equal(T.ImageTexture(tmp_path / "z.exr").image[..., 0], g)
    _write_exr_channels(tmp_path / "layer.exr", {"diffuse.R": r, "diffuse.G": g, "diffuse.B": b})
    np.testing.assert_array_equal(T.ImageTexture(tmp_path / "layer.exr").image, np.stack([r, g, b], axis=-1))
    _write_exr_channels(tmp_path / "xq.exr", {"X": r, "Q": g})
    with pytest.raises(T.TextureError, match=r"xq.exr.*not RGB\(A\), Y or a single channel"):
        T.ImageTexture(tmp_path / "xq.exr")


def test_missing_file_error_names_the_file(tmp_path):
    path = tmp_path / "nope.png"
    with pytest.raises(T.TextureError, match="nope.png"):
        T.ImageTexture(path)


def test_unreadable_file_error_names_the_file(tmp_path):
    path = tmp_path / "broken.png"
    path.write_bytes(b"this is not a png")
    with pytest.raises(T.TextureError, match="broken.png"):
        T.ImageTexture(path)
    exr = tmp_path / "broken.exr"
    exr.write_bytes(b"nor an exr")
    with pytest.raises(T.TextureError, match="broken.exr"):
        T.ImageTexture(exr)


def test_wrong_channel_count_error_names_the_file(tmp_path):
    from skimage import io as skio

    skio.imsave(tmp_path / "grey.png", np.zeros((4, 4), np.uint8), check_contrast=False)
    with pytest.raises(T.TextureError, match="grey.png.*1 channel"):
        T.ImageTexture(tmp_path / "grey.png", channels=3)
    with pytest.raises(T.TextureError, match="grey.png"):
        T.NormalMap(tmp_path / "grey.png")
    skio.imsave(tmp_path / "rgb.png", np.zeros((4, 4, 3), np.uint8), check_contrast=False)
    with pytest.raises(T.TextureError, match="rgb.png.*select"):
        T.ImageTexture(tmp_path / "rgb.png", channels=1)
    assert T.ImageTexture(tmp_path / "rgb.png", select=1, srgb=False).channels == 1
    with pytest.raises(T.TextureError, match="6 channels"):
        T.ImageTexture(np.zeros((2, 2, 6)))


def test_non_finite_texels_error_names_the_file(tmp_path):
    img = np.ones((4, 4, 3), np.float32)
    img[2, 1, 0] = np.nan
    _write_exr(tmp_path / "nan.exr", img)
    with pytest.raises(T.TextureError, match=r"nan.exr.*non-finite.*row 2, column 1"):
        T.ImageTexture(tmp_path / "nan.exr")
    img[2, 1, 0] = np.inf
    with pytest.raises(T.TextureError, match="non-finite"):
        T.ImageTexture(img)


def test_bad_parameters_raise():
    img = np.zeros((2, 2, 3))
    with pytest.raises(T.TextureError, match="filter"):
        T.ImageTexture(img, filter="lanczos")
    with pytest.raises(T.TextureError, match="wrap"):
        T.ImageTexture(img, wrap="tile")
    with pytest.raises(T.TextureError, match="footprint_scale"):
        T.ImageTexture(img, footprint_scale=0)


# ----------------------------------------------------------------------------- procedural textures

def test_constant_texture():
    ctx = ctx_of(np.zeros((3, 2)))
    np.testing.assert_array_equal(T.ConstantTexture(0.3).evaluate(ctx), np.full((3, 1), 0.3))
    np.testing.assert_array_equal(T.ConstantTexture([1, 2, 3]).evaluate(ctx), np.tile([1.0, 2, 3], (3, 1)))


def test_checker_texture_point_and_filtered(rng):
    tex = T.CheckerTexture([1, 0, 0], [0, 0, 1], scale=4.0)
    ctx = ctx_of([[0.1, 0.1], [0.3, 0.1]])
    np.testing.assert_array_equal(tex.evaluate(ctx), [[1, 0, 0], [0, 0, 1]])
    # A footprint spanning whole cells averages the two colours.
    uv = rng.random((50, 2))
    big = ctx_of(uv, np.full((50, 2), [0.5, 0.0]), np.full((50, 2), [0.0, 0.5]))
    np.testing.assert_allclose(tex.evaluate(big), np.tile([0.5, 0, 0.5], (50, 1)), atol=1e-12)
    unf = T.CheckerTexture([1, 0, 0], [0, 0, 1], scale=4.0, filtered=False)
    assert set(np.unique(unf.evaluate(big)[:, 0])) <= {0.0, 1.0}


def test_checker_texture_object_space():
    tex = T.CheckerTexture(0.0, 1.0, scale=1.0, space="object")
    p = np.array([[0.5, 0.5, 0.5], [1.5, 0.5, 0.5], [1.5, 1.5, 0.5]])
    n = len(p)
    ctx = ctx_of(np.zeros((n, 2)), p=p, p_object=p, dpdu=np.zeros((n, 3)), dpdv=np.zeros((n, 3)))
    np.testing.assert_array_equal(tex.evaluate(ctx)[:, 0], [0, 1, 0])


@pytest.mark.parametrize("cls", [T.NoiseTexture, T.PerlinTexture, T.FbmTexture, T.VoronoiTexture])
def test_noise_textures_deterministic_and_in_range(cls, rng):
    uv = rng.uniform(0, 3, (500, 2))
    a = cls(seed=3, low=[0, 0, 0], high=[1, 2, 3]).evaluate(ctx_of(uv))
    b = cls(seed=3, low=[0, 0, 0], high=[1, 2, 3]).evaluate(ctx_of(uv))
    assert a.shape == (500, 3)
    np.testing.assert_array_equal(a, b)
    assert np.all(a >= 0) and np.all(a <= np.array([1, 2, 3]))
    assert cls(seed=3).evaluate(ctx_of(uv)).shape == (500, 1)


def test_fbm_texture_minified_tends_to_its_mean(rng):
    uv = rng.uniform(0, 3, (500, 2))
    d = np.full((500, 2), [10.0, 0.0])
    v = T.FbmTexture(scale=4.0).evaluate(ctx_of(uv, d, d[:, ::-1].copy()))
    np.testing.assert_allclose(v, 0.5, atol=1e-12)


def test_procedural_bad_parameters():
    with pytest.raises(T.TextureError, match="space"):
        T.PerlinTexture(space="world")
    with pytest.raises(T.TextureError, match="seed"):
        T.PerlinTexture(seed="abc")
    with pytest.raises(T.TextureError, match="output"):
        T.VoronoiTexture(output="f3")
    with pytest.raises(T.TextureError, match="octaves"):
        T.FbmTexture(octaves=0)


def test_texture_from_dict(tmp_path):
    tex = T.texture_from_dict({"type": "checker", "color0": 0.1, "color1": {"type": "perlin", "seed": 2}})
    assert isinstance(tex, T.CheckerTexture) and isinstance(tex.color1, T.PerlinTexture)
    with pytest.raises(T.TextureError, match="type"):
        T.texture_from_dict({"type": "marble"})
    with pytest.raises(T.TextureError, match="x.png"):
        T.texture_from_dict({"type": "image", "path": "x.png"}, base_dir=str(tmp_path))


# ----------------------------------------------------------------------------- normal maps

def _frame_ctx(n, rng, uv=None):
    ns = rng.normal(size=(n, 3))
    ns /= np.linalg.norm(ns, axis=1, keepdims=True)
    dpdu = rng.normal(size=(n, 3))
    dpdv = rng.normal(size=(n, 3))
    uv = rng.random((n, 2)) if uv is None else uv
    return ctx_of(uv, ns=ns, dpdu=dpdu, dpdv=dpdv)


@pytest.mark.parametrize("filt", ["bilinear", "trilinear"])
def test_flat_normal_map_changes_nothing(filt, rng):
    ctx = _frame_ctx(1000, rng)
    nm = T.NormalMap(T.flat_normal_map(8, 8), filter=filt)
    out = T.perturb_normal(ctx, nm)
    np.testing.assert_array_equal(out, ctx.ns)


def test_flat_normal_map_from_8bit_png_is_within_8bit_precision(tmp_path, rng):
    from skimage import io as skio

    skio.imsave(tmp_path / "flat.png", np.tile(np.array([128, 128, 255], np.uint8), (4, 4, 1)),
                check_contrast=False)
    ctx = _frame_ctx(100, rng)
    out = T.perturb_normal(ctx, T.NormalMap(tmp_path / "flat.png"))
    # 128/255 encodes 1/255 instead of 0: tilt <= atan(sqrt(2)/255) = 0.32 degrees.
    cos = np.sum(out * ctx.ns, axis=1)
    assert np.all(cos > np.cos(np.deg2rad(0.33)))


def test_tilted_normal_map_rotates_toward_the_tangent(rng):
    a = np.deg2rad(30)
    ns = np.tile([0.0, 0.0, 1.0], (4, 1))
    dpdu = np.tile([2.0, 0.0, 0.5], (4, 1))  # not orthogonal to ns: Gram-Schmidt -> +x
    dpdv = np.array([[0, 1.0, 0], [0, 1.0, 0], [0, -1.0, 0], [0, -1.0, 0]])  # mirrored UVs in 2, 3
    ctx = ctx_of(rng.random((4, 2)), ns=ns, dpdu=dpdu, dpdv=dpdv)
    img = np.broadcast_to((np.array([np.sin(a), 0, np.cos(a)]) + 1) / 2, (2, 2, 3)).copy()
    out = T.perturb_normal(ctx, T.NormalMap(img))
    np.testing.assert_allclose(out, np.tile([np.sin(a), 0, np.cos(a)], (4, 1)), atol=1e-12)
    # Green = +v: follows dpdv, including mirrored UVs.
    img = np.broadcast_to((np.array([0, np.sin(a), np.cos(a)]) + 1) / 2, (2, 2, 3)).copy()
    out = T.perturb_normal(ctx, T.NormalMap(img))
    want = np.array([[0, np.sin(a), np.cos(a)]] * 2 + [[0, -np.sin(a), np.cos(a)]] * 2)
    np.testing.assert_allclose(out, want, atol=1e-12)
    # flip_green reverses it; strength 0 is flat.
    out = T.perturb_normal(ctx, T.NormalMap(img, flip_green=True))
    np.testing.assert_allclose(out[:2], [[0, -np.sin(a), np.cos(a)]] * 2, atol=1e-12)
    np.testing.assert_array_equal(T.perturb_normal(ctx, T.NormalMap(img, strength=0.0)), ns)


def test_normal_map_unit_and_degenerate_frames(rng):
    ctx = _frame_ctx(500, rng)
    ctx.dpdu[:100] = 0.0  # no UV derivatives -> fallback frame
    ctx.dpdu[100:200] = ctx.ns[100:200] * 3.0  # dpdu parallel to ns
    img = rng.random((16, 16, 3))
    out = T.perturb_normal(ctx, T.NormalMap(img))
    assert np.all(np.isfinite(out))
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1.0, atol=1e-12)


def test_shaders_do_not_import_pyrt():
    import shaders

    root = os.path.dirname(shaders.__file__)
    for name in ("textures.py", "noise.py"):
        with open(os.path.join(root, name)) as f:
            src = f.read()
        assert "import pyrt" not in src and "from pyrt" not in src and "embreex" not in src


def test_trilinear_plan_without_footprints_is_level_0_bilinear_bit_for_bit(monkeypatch):
    """Zero footprints everywhere take trilinear_plan's shortcut (no level selection, no sort): the same values, bit
    for bit, as the general path gives for footprints far below one texel (level 0 with weight 1), and as a plain
    bilinear lookup of level 0; coded (uint8) texels through the decode table too."""
    rng = np.random.default_rng(7)
    img = rng.random((32, 16, 3)).astype(np.float32)
    levels = [img] + [K.build_mip_level(img, k) for k in range(1, K.n_mip_levels(img.shape))]
    uv = rng.uniform(-1.0, 2.0, (500, 2))
    zero = np.zeros((500, 2))
    tiny = np.full((500, 2), 1e-9)                      # a footprint of ~3e-8 texels: level 0, general path
    for wrap in ("repeat", "clamp", "mirror"):
        fast = K.lookup_trilinear(levels, uv, zero, zero, wrap)
        general = K.lookup_trilinear(levels, uv, tiny, tiny, wrap)
        np.testing.assert_array_equal(fast, general)
        np.testing.assert_array_equal(fast, K.lookup_bilinear(img, uv, wrap))
    codes = rng.integers(0, 256, (16, 16, 3), dtype=np.uint8)
    table = np.linspace(0.0, 1.0, 256).astype(np.float32) ** 2
    lv = [codes] + [K.build_mip_level(table[codes], k) for k in range(1, K.n_mip_levels(codes.shape))]
    np.testing.assert_array_equal(K.lookup_trilinear(lv, uv, zero, zero, table=table),
                                  K.lookup_trilinear(lv, uv, tiny, tiny, table=table))
    n, steps = K.trilinear_plan(img.shape, len(levels), uv[:0], zero[:0], zero[:0])
    assert n == 0 and steps == []

    def no_level_selection(*a, **k):
        raise AssertionError("the shortcut selects no level")
    monkeypatch.setattr(K, "mip_level_isotropic", no_level_selection)
    np.testing.assert_array_equal(K.lookup_trilinear(levels, uv, zero, zero), K.lookup_bilinear(img, uv))


@pytest.mark.parametrize("filt", ["nearest", "bilinear", "bicubic", "trilinear", "anisotropic"])
def test_constant_channels_skip_the_lookup_and_give_its_value(filt):
    """A channel that is the same in every texel (MipPyramid.constant_channels) is returned without a lookup, with
    the value every filter gives there (a weighted mean of equal texels: equal up to the weights' rounding); a
    varying channel of the same image is still looked up."""
    rng = np.random.default_rng(3)
    img = np.empty((64, 32, 3), dtype=np.uint8)
    img[..., 0] = 200                                   # constant
    img[..., 1] = rng.integers(0, 256, (64, 32))        # varies
    img[..., 2] = 7
    tex = T.ImageTexture(img, srgb=False, filter=filt)
    const = tex._pyramid.constant_channels()
    np.testing.assert_array_equal(np.isnan(const), [False, True, False])
    assert const[0] == np.float32(200 / 255) and const[2] == np.float32(7 / 255)
    n = 500
    uv = rng.random((n, 2)) * 3 - 1
    d = rng.normal(scale=0.05, size=(n, 2))
    ctx = ctx_of(uv, d, d[:, ::-1])
    looked_up = tex.lookup(uv, d, d[:, ::-1])
    for c in (0, 2):
        got = ChannelTexture(tex, c).evaluate(ctx)
        assert got.shape == (n, 1) and np.all(got == const[c])
        np.testing.assert_allclose(got[:, 0], looked_up[:, c], rtol=1e-6)
    assert ChannelTexture(tex, 1).evaluate(ctx_of(uv, d, d[:, ::-1])).std() > 0
    # an image whose every channel is constant: no lookup at all (no MIP level is built)
    flat = T.ImageTexture(np.full((64, 64, 3), (10, 128, 250), dtype=np.uint8), filter=filt)
    v = flat.evaluate(ctx_of(uv, d, d[:, ::-1]))
    assert flat.mip_levels_built == [] and v.shape == (n, 3)
    np.testing.assert_allclose(v, flat.lookup(uv, d, d[:, ::-1]), rtol=1e-6)


@pytest.mark.parametrize("case", ["L", "RGB", "RGBA", "1", "I;16", "jpeg_rgb", "jpeg_grey", "jpeg_progressive"])
def test_still_png_and_jpeg_read_as_skimage_reads_them(tmp_path, rng, case):
    """Still PNGs and JPEGs are read with Pillow alone (no skimage / scipy import at start-up): the array (dtype,
    shape, values) is the one ``skimage.io.imread`` returns, which read_image used to return."""
    from PIL import Image
    from skimage import io as skio

    from pyrt.core.image_io import read_image

    shapes = {"L": (5, 7), "RGB": (5, 7, 3), "RGBA": (5, 7, 4), "1": (5, 7), "I;16": (5, 7),
              "jpeg_rgb": (16, 24, 3), "jpeg_grey": (16, 24), "jpeg_progressive": (16, 24, 3)}
    hi = 65536 if case == "I;16" else 2 if case == "1" else 256
    arr = rng.integers(0, hi, shapes[case]).astype(np.uint16 if case == "I;16" else np.uint8)
    if case == "1":
        im = Image.fromarray(arr.astype(bool))
    else:
        im = Image.fromarray(arr)
    path = tmp_path / ("a.jpg" if case.startswith("jpeg") else "a.png")
    im.save(path, **({"progressive": True} if case == "jpeg_progressive" else {}))
    got, want = read_image(path), np.asarray(skio.imread(path))
    assert got.dtype == want.dtype and got.shape == want.shape
    np.testing.assert_array_equal(got, want)
    assert got.flags.writeable
    if not case.startswith("jpeg"):
        np.testing.assert_array_equal(got, arr.astype(bool) if case == "1" else arr)


def test_reading_a_png_does_not_import_skimage(tmp_path):
    """The previewer's start-up: decoding a glTF's PNG / JPEG textures imports neither skimage nor scipy (~0.3 s)."""
    import subprocess
    import sys

    from PIL import Image

    Image.fromarray(np.zeros((4, 4, 3), np.uint8)).save(tmp_path / "a.png")
    Image.fromarray(np.zeros((4, 4, 3), np.uint8)).save(tmp_path / "a.jpg")
    code = (f"LIGHT = {_NUMBA_SCIPY!r}; import sys; from pyrt.core.image_io import read_image; "
            f"read_image({str(tmp_path / 'a.png')!r}); read_image({str(tmp_path / 'a.jpg')!r}); "
            "print(sorted({m.split('.')[0] for m in sys.modules if m not in LIGHT} & {'skimage', 'scipy'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_animated_png_still_reads_as_skimage_reads_it(tmp_path, rng):
    """An animated PNG is left to skimage.io (imageio stacks its frames), as before."""
    from PIL import Image
    from skimage import io as skio

    from pyrt.core.image_io import read_image

    frames = [Image.fromarray(rng.integers(0, 256, (4, 5, 3), dtype=np.uint8)) for _ in range(2)]
    frames[0].save(tmp_path / "a.png", save_all=True, append_images=frames[1:])
    got, want = read_image(tmp_path / "a.png"), np.asarray(skio.imread(tmp_path / "a.png"))
    assert got.shape == want.shape == (2, 4, 5, 3)
    np.testing.assert_array_equal(got, want)
