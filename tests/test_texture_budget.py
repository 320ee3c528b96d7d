"""The texture budget (pyrt.io.assets.texture_budget): images longer than max_texture are reduced by a power of two
as they are decoded, to pyrt's own MIP level (up to rounding to codes), named in the warnings; the previewer's
"auto" budget follows the output size."""
import numpy as np
import pytest

from test_gltf_materials import _quad, write_gltf
from pyrt.apps.preview.options import PreviewError, PreviewOptions
from pyrt.io.assets import load_asset
from pyrt.io.assets.texture_budget import reduce_texels, reduction_factor
from pyrt.shaders.color import srgb_encode
from pyrt.shaders.mip import reduce_levels
from pyrt.textures.image import decode_table


def test_reduction_factor_is_the_power_of_two_that_fits():
    assert reduction_factor((8192, 8192, 3), 2048) == 4
    assert reduction_factor((4097, 100, 3), 2048) == 4
    assert reduction_factor((2048, 1024, 3), 2048) == 1
    assert reduction_factor((9000, 9000), None) == 1


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("f", [2, 4, 8])
def test_reduced_codes_are_the_mip_level_within_half_a_code(dtype, f):
    """Colour channels: the linear-light MIP level, sRGB-encoded; alpha / data: the MIP level of the code values;
    both rounded to codes (|error| <= 0.5 code, plus float32's rounding of the level: top x 2^-22). Odd sizes drop
    their last rows / columns."""
    rng = np.random.default_rng(f)
    top = np.iinfo(dtype).max
    a = (rng.random((8 * 37 + 3, 8 * 21 + 5, 4)) * top).astype(dtype)
    r = reduce_texels(a, f, srgb_channels=3)
    h, w = a.shape[0] // f, a.shape[1] // f
    assert r.shape == (h, w, 4) and r.dtype == dtype
    crop = a[:h * f, :w * f]
    lin = reduce_levels(decode_table(dtype, "srgb")[crop[..., :3]], f.bit_length() - 1)
    alpha = reduce_levels(decode_table(dtype, "linear")[crop[..., 3:]], f.bit_length() - 1)
    tol = 0.5 + top * 2.0 ** -22
    assert np.abs(r[..., :3] - srgb_encode(lin).astype(np.float64) * top).max() <= tol
    assert np.abs(r[..., 3:] - alpha.astype(np.float64) * top).max() <= tol


def test_loader_reduces_colour_images_in_linear_light_and_names_them(tmp_path):
    """A black/white checker of 1-texel squares averages to linear 0.5 (sRGB code 188) as a base colour or any other
    colour slot (an extension's: the sheen colour), to code 127.5 (rounded 128) as a data map (metallic-roughness)."""
    chk = ((np.indices((64, 64)).sum(axis=0) % 2) * 255).astype(np.uint8)
    img = np.repeat(chk[:, :, None], 3, axis=2)
    mats = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicRoughnessTexture": {"index": 1}},
             "extensions": {"KHR_materials_sheen": {"sheenColorFactor": [1, 1, 1], "sheenColorTexture": {"index": 2}}}}]
    path = write_gltf(tmp_path / "t.gltf", [_quad()], mats, images=[img, img.copy(), img.copy()])
    full = load_asset(path)
    assert not any("texture budget" in w for w in full.warnings)
    a = load_asset(path, max_texture=16)
    notes = [w for w in a.warnings if "texture budget" in w]
    assert len(notes) == 3 and "64x64 read at 16x16" in notes[0] and "MIP level 2" in notes[0]
    base = a.materials[0].base_color_texture.texture.texels
    mr = a.materials[0].metallic_roughness_texture.texture.texels
    assert base.shape[:2] == (16, 16) and np.all(base[..., :3] == 188)
    assert mr.shape[:2] == (16, 16) and np.all(mr[..., :3] == 128)
    assert np.all(a.materials[0].sheen_color_texture.texture.texels[..., :3] == 188)


def test_preview_budget_follows_the_output_size():
    assert PreviewOptions().texture_budget() == 2048                    # 640 x 480: 3 x 640 = 1920 -> 2048
    assert PreviewOptions(width=1920, height=1080).texture_budget() == 8192
    assert PreviewOptions(max_texture=0).texture_budget() is None
    assert PreviewOptions(max_texture=1000).texture_budget() == 1000
    with pytest.raises(PreviewError, match="max_texture"):
        PreviewOptions(max_texture=-1).validate()


def test_obj_colour_maps_are_reduced_in_linear_light(tmp_path):
    from PIL import Image
    chk = ((np.indices((64, 64)).sum(axis=0) % 2) * 255).astype(np.uint8)
    Image.fromarray(np.repeat(chk[:, :, None], 3, axis=2)).save(tmp_path / "c.png")
    (tmp_path / "m.mtl").write_text("newmtl m\nKd 1 1 1\nmap_Kd c.png\n")
    (tmp_path / "m.obj").write_text("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nusemtl m\n"
                                    "f 1/1 2/2 3/3\n")
    a = load_asset(str(tmp_path / "m.obj"), max_texture=32)
    tex = a.materials[0].map_Kd
    assert tex.texels.shape[:2] == (32, 32) and np.all(tex.texels == 188)
    assert any("map_Kd" in w and "64x64 read at 32x32" in w for w in a.warnings)
