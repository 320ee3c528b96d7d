"""The compiled texture table's texels (:func:`pyrt.textures.compiled.pack_table`): float32 words after the float64
records, the pyramid's own values bit for bit, each level where its record says, nothing built that no lookup reads,
and a table about the size of the float32 texels it holds."""
import numba
import numpy as np
import pytest

import pyrt
from pyrt.core.unmanaged import float32_pointer, pointer
from pyrt.integrators import compiled
from pyrt.textures import compiled as TC
from pyrt.shaders.textures import n_mip_levels
from pyrt.textures.compiled_mip import TexelBlock


@numba.njit(cache=False)
def _words(data, k):
    """Float32 word ``k`` of ``data`` read through :func:`float32_pointer` of the array and of its pointer."""
    return float32_pointer(data)[k], float32_pointer(pointer(data))[k]


def test_float32_pointer_reads_the_same_bytes_as_float32():
    data = np.arange(6, dtype=np.float64) * 1.25 + 0.1
    words = data.view(np.float32)
    for k in range(words.size):
        a, b = _words(data, k)
        assert np.float32(a).tobytes() == words[k].tobytes() and np.float32(b).tobytes() == words[k].tobytes()


def _coded(rng, h, w, dtype=np.uint8):
    return rng.integers(0, np.iinfo(dtype).max + 1, (h, w, 3)).astype(dtype)


def _levels(tex, data):
    """Each level of a MIP texture as the table holds it (field 15: the level offsets in float64 words)."""
    tags, flat = data
    row = [t for t in range(tags.size) if tags[t] == TC.MIP][0]
    rec = flat[row]
    words = flat.ravel().view(np.float32)
    out = []
    for k in range(int(rec[5])):
        at = int(flat.ravel()[int(rec[15]) + k])
        shape = tex.texels.shape if k == 0 else tex.mip_level(k).shape
        out.append(words[at:at + int(np.prod(shape))].reshape(shape))
    assert int(flat.ravel()[int(rec[15])]) == int(rec[2])         # level 0 starts where field 2 says
    return out


@pytest.mark.parametrize("dtype", [np.float32, np.uint8, np.uint16])
def test_the_table_holds_the_pyramids_float32_texels_bit_for_bit(dtype, rng, monkeypatch):
    """8-bit, 16-bit (decoded strip by strip: odd height, strips of 3 rows) and float32 level 0, every level of the
    pyramid the NumPy lookups read, bit for bit, next to an IMAGE texture whose level 0 follows them."""
    monkeypatch.setattr(TexelBlock, "STRIP_ROWS", 3)
    img = _coded(rng, 11, 20, dtype) if dtype != np.float32 else rng.random((11, 20, 3)).astype(np.float32)
    mip = pyrt.ImageTexture(img, filter="trilinear", srgb=dtype != np.float32)
    flat_img = pyrt.ImageTexture(_coded(rng, 5, 7), filter="bilinear")
    recs = [t.compiled_record() for t in (flat_img, mip)]
    data = TC.pack_table([r[0] for r in recs], [r[1] for r in recs], [r[2] for r in recs])
    got = _levels(mip, data)
    want = [mip.image] + [mip.mip_level(k) for k in range(1, len(got))]
    assert len(got) == n_mip_levels(img.shape) == 5
    for g, w in zip(got, want):
        assert w.dtype == np.float32
        assert g.tobytes() == w.tobytes()
    at = int(data[1][0, 2])
    words = data[1].ravel().view(np.float32)
    assert words[at:at + 5 * 7 * 3].tobytes() == flat_img.image.tobytes()


def test_nearest_and_bilinear_textures_pack_level_0_alone_and_build_no_pyramid(rng):
    tex = pyrt.ImageTexture(_coded(rng, 64, 32), filter="bilinear")
    tags, data = TC.pack_table(*([x] for x in tex.compiled_record()))
    assert tex.mip_levels_built == []
    assert data.nbytes <= TC.RECORD * 8 + 64 * 32 * 3 * 4 + TC.RECORD * 8       # record, level 0 float32, padding


def test_packing_reuses_a_pyramid_already_built():
    """A pyramid the NumPy side built (before the workers fork) is copied into the table, not built again."""
    tex = pyrt.ImageTexture(_coded(np.random.default_rng(3), 32, 32), filter="trilinear")
    tex.build_mip_levels()
    before = [tex.mip_level(k) for k in range(1, 6)]
    TC.pack_table(*([x] for x in tex.compiled_record()))
    assert all(tex.mip_level(k) is lev for k, lev in zip(range(1, 6), before))


def test_a_textured_scenes_table_is_about_its_float32_pyramids(rng):
    """Two trilinear maps (8-bit sRGB, 256² and 128 x 64) and a bilinear one on a packed scene: the table is the
    float32 bytes of their texels (whole pyramids, level 0 of the bilinear one) plus the records and level offsets,
    within one padding row (the float64 table was twice that)."""
    a = pyrt.ImageTexture(_coded(rng, 256, 256), filter="trilinear")
    b = pyrt.ImageTexture(_coded(rng, 128, 64), filter="trilinear")
    c = pyrt.ImageTexture(_coded(rng, 40, 30), filter="bilinear")
    cam = pyrt.Camera(position=(0, 1.5, 3.0), target=(0, 0, 0), fov=40, width=8, height=6, spp=1)
    s = pyrt.Scene(cam, background=0.1)
    for x, tex in zip((-1.0, 0.0, 1.0), (a, b, c)):
        s.add_sphere((x, 0, 0), 0.4, pyrt.Lambert(albedo=tex))
    s.add_light(pyrt.PointLight((1, 2, 1), intensity=8.0))
    with pyrt.PreparedScene(s) as ps:
        tags, data = compiled.CompiledScene(ps).textures
    pyramids = sum(4 * TexelBlock(t, n_mip_levels(t.texels.shape)).size for t in (a, b))
    texels = pyramids + 4 * c.texels.size
    head = 8 * (3 * TC.RECORD + 9 + 8)                                # records, level offsets
    assert data.dtype == np.float64 and tags.size == 3
    assert texels + head <= data.nbytes <= texels + head + 8 * TC.RECORD
    assert data.nbytes <= 1.4 * pyramids
