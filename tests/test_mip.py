"""Tests for shaders/mip.py (the 2x2 cascade) and the lazy float32 pyramid of ImageTexture.

Ground truths: a float64 reference cascade of exact box (area) averages (``build_mip_level``'s filter
applied level by level, and for power-of-two sizes the area average of level 0 itself); the image
mean, which every exact box step preserves; the byte count of a 4/3 pyramid.
"""
import numpy as np
import pytest

from pyrt.shaders import mip as M
from pyrt.shaders import textures as K
from pyrt import textures as T


@pytest.fixture
def rng():
    return np.random.default_rng(2024)


def _reference_cascade(img, n_levels):
    """float64 levels: each the exact area average of the previous one (``build_mip_level`` one step)."""
    levels = [np.asarray(img, dtype=np.float64)]
    for _ in range(1, n_levels):
        prev = levels[-1]
        h, w = max(1, prev.shape[0] // 2), max(1, prev.shape[1] // 2)
        levels.append(K._box_resample_axis(K._box_resample_axis(prev, h, 0), w, 1))
    return levels


@pytest.mark.parametrize("shape", [(64, 64), (37, 53), (1, 17), (5, 1), (100, 3), (3, 3), (7, 2)])
def test_float32_cascade_equals_float64_reference_to_rounding(shape, rng):
    img = rng.random(shape + (3,), dtype=np.float32)
    n = K.n_mip_levels(img.shape)
    ref = _reference_cascade(img, n)
    tex = T.ImageTexture(img, srgb=False)
    pyr = tex._pyramid
    for lev in range(n):
        got = pyr[lev]
        assert got.dtype == np.float32
        assert got.shape[:2] == K.mip_level_shape(img.shape, lev)
        np.testing.assert_allclose(got, ref[lev], rtol=4e-6 * (1 + lev), atol=1e-7)
        np.testing.assert_allclose(got.mean(axis=(0, 1)), img.astype(np.float64).mean(axis=(0, 1)), rtol=1e-5)


def test_power_of_two_cascade_is_the_area_average_of_level_0(rng):
    img = rng.random((32, 16, 2))
    for lev in range(K.n_mip_levels(img.shape)):
        np.testing.assert_allclose(M.reduce_levels(img, lev), K.build_mip_level(img, lev), atol=1e-14)


def test_odd_axis_is_the_exact_area_average_of_the_previous_level():
    # 5 -> 2: cells [0, 2.5), [2.5, 5); 2 -> 1: the pair mean. 3 -> 1: the plain mean.
    img = np.array([[[1.0], [2.0], [6.0], [3.0], [5.0]]])
    lev1 = M.reduce_level(img)
    np.testing.assert_allclose(lev1[0, :, 0], [(1 + 2 + 0.5 * 6) / 2.5, (0.5 * 6 + 3 + 5) / 2.5])
    np.testing.assert_allclose(M.reduce_level(lev1)[0, :, 0], [17 / 5])
    np.testing.assert_allclose(M.reduce_axis(np.array([1.0, 2.0, 6.0]), 0), [3.0])
    # 7 -> 3: cells of width 7/3, four taps for the middle one.
    a = np.arange(7, dtype=np.float64) ** 2
    r = 7 / 3
    cum = lambda x: np.sum(a[:int(np.floor(x))]) + (x - np.floor(x)) * a[min(int(np.floor(x)), 6)]
    want = [(cum((k + 1) * r) - cum(k * r)) / r for k in range(3)]
    np.testing.assert_allclose(M.reduce_axis(a, 0), want, rtol=1e-14)


def test_dtype_kept_and_integers_promoted():
    assert M.reduce_level(np.zeros((4, 4, 3), np.float32)).dtype == np.float32
    assert M.reduce_level(np.zeros((4, 4, 3), np.float64)).dtype == np.float64
    assert M.reduce_level(np.zeros((4, 4), np.uint8)).dtype == np.float64
    with pytest.raises(ValueError, match="steps"):
        M.reduce_levels(np.zeros((4, 4)), -1)


def test_levels_are_the_same_whatever_order_they_are_built_in(rng):
    img = rng.random((45, 30, 3), dtype=np.float32)
    a = T.ImageTexture(img, srgb=False)._pyramid
    b = T.ImageTexture(img, srgb=False)._pyramid
    n = len(a)
    for lev in range(1, n):
        a[lev]
    for lev in (4, 2, n - 1, 1, 3):
        np.testing.assert_array_equal(b[lev], a[lev])


def test_pyramid_memory_of_a_2048_rgb_texture():
    img = np.zeros((2048, 2048, 3), dtype=np.float32)
    tex = T.ImageTexture(img, srgb=False)
    pyr = tex._pyramid
    for lev in range(1, len(pyr)):
        assert pyr[lev].dtype == np.float32
    assert pyr.built == list(range(1, 12))
    assert pyr.nbytes < 1.4 * 2048 * 2048 * 3 * 4


def test_lazy_level_skips_unread_levels(rng):
    tex = T.ImageTexture(rng.random((64, 64, 1)), filter="trilinear")
    ref = _reference_cascade(tex.image, 5)
    np.testing.assert_allclose(tex._pyramid[4], ref[4], rtol=2e-5)
    assert tex.mip_levels_built == [4]
    tex._pyramid[5]  # from level 4, not from level 0
    assert tex.mip_levels_built == [4, 5]


# ----------------------------------------------------------------------------- decode once (asset loaders)

def test_shared_texture_keeps_texels_and_checks_decoding(rng):
    base = T.ImageTexture(rng.random((8, 8, 3)), srgb=False, name="a")
    other = T.ImageTexture(base, wrap="clamp", scale=(2.0, 2.0))
    assert other._image is base._image and other._pyramid is base._pyramid
    assert other.wrap != base.wrap and other.decode == "linear"
    other._pyramid[2]
    assert base.mip_levels_built == [2]
    nm = T.NormalMap(base, strength=0.5)
    assert nm._pyramid is base._pyramid
    with pytest.raises(T.TextureError, match="decoded"):
        T.ImageTexture(base, srgb=True)
    with pytest.raises(T.TextureError, match="select"):
        T.ImageTexture(base, select=0)
    with pytest.raises(T.TextureError, match="channel"):
        T.ImageTexture(base, channels=1)


def _two_material_glb(tmp_path, rng):
    """A GLB whose two materials use image 0 as base colour and image 1 as metallicRoughness + occlusion,
    material 1 through a second sampler (clamp) and texture entry."""
    import trimesh
    from PIL import Image
    from trimesh.visual.material import PBRMaterial
    from pyrt.io.assets import pack_glb, read_gltf
    box = trimesh.creation.box()
    img = lambda: Image.fromarray(rng.integers(0, 256, size=(8, 8, 3), dtype=np.uint8))
    box.visual = trimesh.visual.TextureVisuals(uv=rng.random((len(box.vertices), 2)), material=PBRMaterial(
        baseColorTexture=img(), metallicRoughnessTexture=img()))
    raw = tmp_path / "raw.glb"
    raw.write_bytes(trimesh.Scene(box).export(file_type="glb"))
    header, buffers = read_gltf(raw)
    m0 = header["materials"][0]
    pbr = m0["pbrMetallicRoughness"]
    bi = header["textures"][pbr["baseColorTexture"]["index"]]["source"]
    mi = header["textures"][pbr["metallicRoughnessTexture"]["index"]]["source"]
    assert bi != mi
    header["samplers"] = header.get("samplers", []) + [{"wrapS": 33071, "wrapT": 33071}]
    header["textures"] += [{"source": bi, "sampler": len(header["samplers"]) - 1}, {"source": mi}]
    nt = len(header["textures"])
    m0["occlusionTexture"] = {"index": pbr["metallicRoughnessTexture"]["index"]}
    header["materials"].append({"name": "second", "pbrMetallicRoughness": {
        "baseColorTexture": {"index": nt - 2}, "metallicRoughnessTexture": {"index": nt - 1}},
        "occlusionTexture": {"index": nt - 1}, "emissiveTexture": {"index": nt - 1}})
    out = tmp_path / "two.glb"
    out.write_bytes(pack_glb(header, buffers[0]))
    return str(out)


def test_gltf_images_decoded_once_and_shared(tmp_path, rng, monkeypatch):
    from pyrt.io.assets import load_asset
    from pyrt.textures import image as I
    calls = []
    real = I.prepare_image
    monkeypatch.setattr(I, "prepare_image", lambda *a, **k: calls.append(k.get("decode")) or real(*a, **k))
    a = load_asset(_two_material_glb(tmp_path, rng))
    p0, p1 = a.materials
    b0, b1 = p0.base_color_texture.texture, p1.base_color_texture.texture
    assert b1._image is b0._image and b1._pyramid is b0._pyramid
    assert b0.wrap != b1.wrap                       # own sampler, shared texels
    assert p1.metallic_roughness_texture.texture._image is p0.metallic_roughness_texture.texture._image
    # metallic (B), roughness (G), occlusion (R): channel views of the slot's texture, no copies
    for p in (p0, p1):
        assert isinstance(p.roughness_texture, T.ChannelTexture) and p.roughness_texture.channel == 1
        assert p.metallic_texture.channel == 2 and p.occlusion_texture.channel == 0
        assert p.roughness_texture.source is p.metallic_roughness_texture.texture
        assert p.occlusion_texture.source._image is p.metallic_roughness_texture.texture._image
    # emissive reads the metallicRoughness image as sRGB: the same 8-bit codes, its own table and pyramid
    e, mr = p1.emissive_texture.texture, p1.metallic_roughness_texture.texture
    assert e.decode == "srgb" and e.texels.dtype == np.uint8 and e._image is mr._image
    assert e._pyramid is not mr._pyramid and not np.array_equal(e.table, mr.table)
    # decodes: base (sRGB), mr (linear), emissive (sRGB) -- once each; the channels copy nothing
    assert sorted(map(str, calls)) == sorted(["srgb", "linear", "srgb"])


def test_obj_maps_of_one_file_decoded_once(tmp_path):
    from PIL import Image
    from pyrt.io.assets import load_asset
    (tmp_path / "m.obj").write_text("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\n"
                                    "vt 0 1\nusemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 2/2 4/1 3/3\n")
    (tmp_path / "m.mtl").write_text("newmtl a\nKd 1 1 1\nmap_Kd t.png\nnewmtl b\nKd 1 1 1\n"
                                    "map_Kd -s 2 2 t.png\nmap_Ke ./t.png\n")
    Image.fromarray(np.full((4, 4, 3), 100, np.uint8)).save(tmp_path / "t.png")
    a = load_asset(str(tmp_path / "m.obj"))
    m = {p.name: p for p in a.materials}
    ka, kb, ke = m["a"].map_Kd, m["b"].map_Kd, m["b"].map_Ke
    assert kb._image is ka._image and ke._image is ka._image and kb._pyramid is ka._pyramid
    assert kb.scale == (2.0, 2.0) and ka.scale == (1.0, 1.0)


@pytest.mark.parametrize("shape", [(64, 64, 3), (6, 9, 1), (5, 8, 3), (2, 1, 3), (1, 7), (10, 3)])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_coded_reduction_is_bit_identical_to_decode_then_reduce(shape, dtype, rng):
    codes = rng.integers(0, 256, size=shape).astype(np.uint8)
    table = ((np.arange(256) / 255.0) ** 2.2).astype(dtype)
    want = M.reduce_level(table[codes])
    got = M.reduce_coded_level(codes, table)
    assert got.dtype == want.dtype and got.shape == want.shape
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(M.reduce_coded_level(codes, table, M.pair_table(table)), want)


def test_coded_reduction_refuses_what_it_cannot_pair():
    with pytest.raises(ValueError, match="uint8"):
        M.reduce_coded_level(np.zeros((4, 4), np.uint16), np.zeros(256, np.float32))
    with pytest.raises(ValueError, match="256"):
        M.pair_table(np.zeros(65536, np.float32))
