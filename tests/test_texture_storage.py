"""8/16-bit texels stored as codes, decoded per tap; level 1 built in strips; texture reads once per hit.

Ground truths: the float32 image a decode of the whole image gives (what ImageTexture stored before codes),
the float32 reference cascade of :func:`pyrt.shaders.mip.reduce_levels`, the per-level loop of the trilinear
blend written out, and counted texture evaluations.
"""
import numpy as np
import pytest

from pyrt.geometry import SurfaceBatch
from pyrt.materials import MetallicRoughness
from pyrt.shaders import color
from pyrt.shaders import ewa as E
from pyrt.shaders import mip as M
from pyrt.shaders import textures as K
from pyrt import textures as T
from pyrt.textures import image as I


@pytest.fixture
def rng():
    return np.random.default_rng(7)


def _float_copy(codes, decode):
    """The float32 image the old path stored: codes / max in float32, decoded over the whole image."""
    top = np.iinfo(codes.dtype).max
    x = codes.astype(np.float32) / np.float32(top)
    return {"srgb": color.srgb_decode, "linear": lambda a: a, "gamma2.2": lambda a: color.gamma_decode(a, 2.2)}[decode](x)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("decode", ["srgb", "linear", "gamma2.2"])
def test_decode_table_equals_decoding_the_whole_image(dtype, decode, rng):
    codes = rng.integers(0, np.iinfo(dtype).max + 1, size=(64, 48, 3)).astype(dtype)
    tex = T.ImageTexture(codes, decode=decode)
    assert tex.texels.dtype == dtype and tex.texels.nbytes == codes.nbytes     # 1 or 2 bytes per channel
    assert tex.table.dtype == np.float32 and tex.table.shape == (np.iinfo(dtype).max + 1,)
    np.testing.assert_array_equal(tex.image, _float_copy(codes, decode))      # bit for bit
    assert tex.image.dtype == np.float32


@pytest.mark.parametrize("filt", ["nearest", "bilinear", "bicubic", "trilinear", "anisotropic"])
def test_coded_lookups_equal_lookups_of_the_decoded_float_image(filt, rng):
    codes = rng.integers(0, 256, size=(96, 80, 3)).astype(np.uint8)
    coded = T.ImageTexture(codes, filter=filt)
    ref = T.ImageTexture(_float_copy(codes, "srgb"), srgb=False, filter=filt)
    assert ref.texels.dtype == np.float32 and ref.table is None
    n = 4000
    uv = rng.random((n, 2)) * 3 - 1
    d = rng.normal(size=(n, 2)) * np.exp(rng.uniform(-9, -1, size=(n, 1)))
    d2 = rng.normal(size=(n, 2)) * np.exp(rng.uniform(-9, -1, size=(n, 1)))
    got, want = coded.lookup(uv, d, d2), ref.lookup(uv, d, d2)
    np.testing.assert_array_equal(got, want)
    if filt in ("trilinear", "anisotropic"):
        assert coded.mip_levels_built == ref.mip_levels_built and len(coded.mip_levels_built) > 3


@pytest.mark.parametrize("shape", [(1030, 70, 3), (513, 9, 1), (2, 600, 3), (1, 5, 3)])
def test_first_reduction_in_strips_equals_reducing_the_decoded_image(shape, rng):
    codes = rng.integers(0, 256, size=shape).astype(np.uint8)
    table = I.decode_table(np.uint8, "srgb")
    pyr = T.MipPyramid(codes, table)
    want = M.reduce_levels(table[codes], 1)
    got = pyr[1]
    assert got.dtype == np.float32 and got.shape == want.shape
    np.testing.assert_array_equal(got, want)
    if len(pyr) > 3:
        np.testing.assert_array_equal(T.MipPyramid(codes, table)[3], M.reduce_levels(table[codes], 3))


def test_trilinear_equals_the_per_level_blend(rng):
    img = rng.random((64, 64, 3), dtype=np.float32)
    levels = [M.reduce_levels(img, k) for k in range(K.n_mip_levels(img.shape))]
    n = 3000
    uv = rng.random((n, 2))
    d = rng.normal(size=(n, 2)) * np.exp(rng.uniform(-8, 1, size=(n, 1)))
    lam = K.mip_level_isotropic(d, d[:, ::-1], img.shape)
    l0, l1, w1 = K.trilinear_levels(lam, len(levels))
    want = np.zeros((n, 3))
    for i in range(n):              # the blend written out, lookup by lookup
        want[i] = (1 - w1[i]) * K.lookup_bilinear(levels[l0[i]], uv[i:i + 1])[0]
        if l1[i] != l0[i]:
            want[i] += w1[i] * K.lookup_bilinear(levels[l1[i]], uv[i:i + 1])[0]
    got = K.lookup_trilinear(levels, uv, d, d[:, ::-1])
    assert len(np.unique(l0)) >= 5
    np.testing.assert_allclose(got, want.astype(np.float32), rtol=1e-6, atol=1e-7)


def test_ewa_with_table_equals_ewa_of_decoded_levels(rng):
    codes = rng.integers(0, 256, size=(32, 32, 3)).astype(np.uint8)
    table = I.decode_table(np.uint8, "srgb")
    pyr = T.MipPyramid(codes, table)
    dec = [table[codes]] + [pyr[k] for k in range(1, len(pyr))]
    uv = rng.random((500, 2))
    d = rng.normal(size=(500, 2)) * 0.05
    np.testing.assert_array_equal(E.lookup_ewa(pyr, uv, d, d * [1, -0.2], table=table),
                                  E.lookup_ewa(dec, uv, d, d * [1, -0.2]))


def test_image_files_are_kept_as_codes(tmp_path, rng):
    from PIL import Image
    codes = rng.integers(0, 256, size=(16, 8, 3)).astype(np.uint8)
    Image.fromarray(codes).save(tmp_path / "t.png")
    tex = T.ImageTexture(tmp_path / "t.png")
    np.testing.assert_array_equal(tex.texels, codes)
    np.testing.assert_array_equal(tex.image, _float_copy(codes, "srgb"))
    img, is_int = T.load_image(tmp_path / "t.png")            # the public default is unchanged: float32
    assert is_int and img.dtype == np.float32


# ----------------------------------------------------------------------------- one read per hit

class _Counting(T.ImageTexture):
    """An image texture that counts the rows it evaluates."""

    rows = 0

    def evaluate(self, ctx):
        type(self).rows += ctx.n_hits
        return super().evaluate(ctx)


def test_views_with_repeated_hits_read_textures_once_per_hit(rng):
    n = 500
    tex = _Counting(rng.random((32, 32, 3)), srgb=False)
    mat = MetallicRoughness(base_color=tex)
    z = np.zeros((n, 2))
    surf = SurfaceBatch(uv=rng.random((n, 2)), duvdx=z + 0.01, duvdy=z + 0.01, p=np.zeros((n, 3)))
    group = surf.subset(slice(100, 400))                      # one material's hits
    rows = np.tile(np.arange(300), 4)                         # 4 samples per hit
    _Counting.rows = 0
    got = mat.param(tex, group.subset(rows), 3)
    assert _Counting.rows == 300                              # at the group, not 1200 rows
    np.testing.assert_array_equal(got, np.tile(tex.lookup(surf.uv[100:400], z[:300] + 0.01, z[:300] + 0.01), (4, 1)))
    mat.param(tex, group.subset(np.arange(300)), 3)           # all the group's hits again: cached there
    mat.param(tex, group, 3)
    assert _Counting.rows == 300
    _Counting.rows = 0
    mat.param(tex, group.subset(np.arange(0, 300, 2)), 3)    # a part of a fresh group is read alone
    assert _Counting.rows == 0                                # (cached at the group above)
    g2 = surf.subset(slice(0, 100))
    mat.param(tex, g2.subset(np.arange(0, 100, 2)), 3)
    assert _Counting.rows == 50


def test_channel_textures_share_one_lookup_and_equal_one_channel_copies(rng):
    codes = rng.integers(0, 256, size=(64, 64, 3)).astype(np.uint8)
    src = _Counting(codes, srgb=False, wrap=("repeat", "clamp"), scale=(2.0, 1.5))
    n = 800
    z = np.zeros((n, 2))
    d = rng.normal(size=(n, 2)) * 0.02
    ctx = SurfaceBatch(uv=rng.random((n, 2)), duvdx=d, duvdy=d[:, ::-1] * [1, -1], p=np.zeros((n, 3)))
    _Counting.rows = 0
    views = [T.ChannelTexture(src, c) for c in (2, 1, 0)]
    got = [v.evaluate(ctx) for v in views]
    assert _Counting.rows == n                                 # three channels, one lookup
    for v, g in zip(views, got):
        copy = T.ImageTexture(np.ascontiguousarray(codes[:, :, v.channel]), srgb=False, wrap=src.wrap,
                              scale=src.scale)
        assert g.shape == (n, 1)
        np.testing.assert_array_equal(g, copy.evaluate(ctx))
    other = _Counting(src, wrap="mirror")                      # same texels, another sampler: its own lookup
    T.ChannelTexture(other, 0).evaluate(ctx)
    assert _Counting.rows == 2 * n
    with pytest.raises(T.TextureError, match="channel 3"):
        T.ChannelTexture(src, 3)


@pytest.mark.parametrize("n", [1, 2, 3, 64, 100, 2048])
def test_repeat_wrap_is_the_modulo_for_every_size(n):
    i = np.arange(-5 * n - 3, 5 * n + 4)
    np.testing.assert_array_equal(K.wrap_index(i, n, "repeat"), np.mod(i, n))


def test_channel_texture_reads_its_sources_uv_set(rng):
    codes = rng.integers(0, 256, size=(8, 8, 3)).astype(np.uint8)
    a = T.ImageTexture(codes, srgb=False)
    b = T.ImageTexture(a, texcoord=1)                 # the same texels and pyramid, another UV set
    assert T.ChannelTexture(b, 1).texcoord == 1 and T.ChannelTexture(a, 1).texcoord == 0
    assert a.sampling_key != b.sampling_key          # another UV set: not the same lookup


def test_coded_pyramid_keeps_level_1_and_decodes_level_0_once(rng, monkeypatch):
    codes = rng.integers(0, 256, size=(64, 64, 3)).astype(np.uint8)
    tex = T.ImageTexture(codes)
    calls = []
    real = T.MipPyramid._first_reduction
    monkeypatch.setattr(T.MipPyramid, "_first_reduction", lambda self: calls.append(1) or real(self))
    tex._pyramid[3]
    assert tex.mip_levels_built == [1, 3]
    tex._pyramid[1], tex._pyramid[2], tex._pyramid[5]
    assert len(calls) == 1
    np.testing.assert_array_equal(tex._pyramid[1], M.reduce_levels(tex.image, 1))


def test_loading_and_the_first_level_make_no_float_copy_of_level_0(tmp_path, rng):
    """tracemalloc bounds: an 8-bit PNG is held as its codes (a float32 copy would be 4x their bytes, an sRGB decode
    over the image more), and level 1 is built strip by strip (a decoded level 0 would be 4x the codes)."""
    import tracemalloc
    from PIL import Image
    codes = rng.integers(0, 256, size=(1024, 1024, 3)).astype(np.uint8)
    Image.fromarray(codes).save(tmp_path / "big.png", compress_level=1)
    Image.fromarray(codes[:4, :4]).save(tmp_path / "small.png")
    T.ImageTexture(tmp_path / "small.png")._pyramid[1]         # the reader's imports happen outside the trace
    tracemalloc.start()
    try:
        tex = T.ImageTexture(tmp_path / "big.png")
        load_peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        tex._pyramid[1]
        level_peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    assert tex.texels.nbytes == codes.nbytes
    assert load_peak < 2.2 * codes.nbytes                      # the codes and the reader's copy, no float image
    level1 = tex._pyramid[1].nbytes                            # float32: codes.nbytes (a quarter of the texels, x4 bytes)
    assert level_peak < level1 + 2.0 * codes.nbytes            # level 1 + one strip's temporaries (measured 1.8x);
    #                                                          a decoded level 0 alone would be 4 x codes
