"""The automatic exposure keeps the shadow catcher's backdrop grey (issue 33): a dark model (a glTF without its
metallic-roughness map, so glTF's defaults make it a rough metal) no longer turns the backdrop white."""
from __future__ import annotations

import json

import numpy as np
import pytest

from pyrt.apps.preview import PreviewOptions, PreviewScene
from pyrt.apps.preview.rig import BACKDROP_MAX, auto_exposure, limit_backdrop
from pyrt.core.image_io import tonemap_to_display
from pyrt.io.assets import load_asset
from pyrt.io.assets.gltf_write import embedded_gltf
from pyrt.apps.preview.cli import _parser
from pyrt.shaders import color


@pytest.mark.parametrize("tonemap", ["reinhard", "pbr_neutral", "aces", "film"])
def test_limit_backdrop_brings_the_backdrop_to_the_limit(tonemap):
    bg = np.array([0.6, 0.65, 0.7])
    e, w = limit_backdrop(4.0, 3.0, bg, tonemap)
    kw = {"L_white": w} if tonemap == "reinhard" else {}
    shown = tonemap_to_display(bg.reshape(1, 1, 3), tonemap_op=tonemap, exposure=e, **kw).max()
    assert e < 4.0 and shown == pytest.approx(BACKDROP_MAX, abs=1e-3)
    assert limit_backdrop(-1.0, 3.0, bg, tonemap) == (-1.0, 3.0)        # a backdrop already grey: unchanged
    assert limit_backdrop(4.0, 3.0, np.zeros(3), tonemap) == (4.0, 3.0)   # no backdrop (no ground)


def test_a_dark_metal_model_keeps_a_grey_backdrop(tmp_path):
    """A sphere-ish box with glTF's default metallic 1 and roughness 1 (no metallicRoughness map): the automatic
    exposure is several stops up, and the backdrop pixels stay at sRGB <= 231, not 255."""
    v = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]],
                 dtype=np.float32)
    f = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4], [3, 7, 6], [3, 6, 2],
                  [0, 4, 7], [0, 7, 3], [1, 2, 6], [1, 6, 5]])
    h = embedded_gltf({"POSITION": v}, f, {"pbrMetallicRoughness": {"baseColorFactor": [0.3, 0.3, 0.3, 1.0]}})
    path = tmp_path / "dark.gltf"
    path.write_text(json.dumps(h))
    ps = PreviewScene(load_asset(str(path)), PreviewOptions(width=48, height=36, spp=2, threads=1))
    try:
        res = ps.render_view(ps.azimuth)
        raw, _ = auto_exposure(res.image, ps.model_mask())
        png = ps.to_display(res.image)
        corner = png[0, 0]                                   # the top-left pixel sees the backdrop
    finally:
        ps.close()
    assert raw > 1.0 and ps.exposure < raw
    assert corner.max() <= 232


def test_gltf_extras_take_the_gltf_record_or_none():
    """A glTF material with emission or occlusion packs the GLTF record, which the kernel evaluates per hit
    (tests/test_compiled_gltf.py); an occlusion the kernel cannot read leaves it without a record (an occlusion
    texture once made the compiled path's record evaluate it on a one-hit context and crash the previewer on
    TextureTransformMultiTest: the record evaluates no texture); without extras it keeps its base model's record."""
    from pyrt.io.assets.materials import GltfMaterial
    from pyrt.materials import compiled as MC
    from pyrt.textures.procedural import CheckerTexture

    def pack(tex):
        return None

    plain = GltfMaterial(base_color=0.5, metallic=0.0, roughness=0.5)
    assert plain.compiled_record(pack)[0] == MC.METALLIC_ROUGHNESS
    occluded = GltfMaterial(base_color=0.5, metallic=0.0, roughness=0.5, occlusion=CheckerTexture(0.2, 1.0))
    assert occluded.compiled_record(pack) is None
    glowing = GltfMaterial(base_color=0.5, metallic=0.0, roughness=0.5, emission=(1.0, 0.5, 0.2))
    tag, rec = glowing.compiled_record(pack)
    assert tag == MC.GLTF and list(rec[10:14]) == [-1.0, 1.0, 0.5, 0.2]


def test_the_default_tone_map_is_pbr_neutral_and_keeps_a_bright_emitter_s_channels_below_white():
    """The previewer's default display (docs/preview.md, "tone map"; tools/tonemap_choice.py measured it on the shared
    Khronos set) is Khronos PBR Neutral at the automatic exposure. EmissiveStrengthTest's cube colour (0.1, 0.5, 0.9) at
    16x, exposed as the rule exposed that model (-1.63 stops), keeps every channel below 255 and goes toward white
    (smallest / largest channel above 0.4), where Reinhard on luminance clips blue and keeps it cyan."""
    assert PreviewOptions().tonemap == "pbr_neutral" and _parser().parse_args(["m.glb"]).tonemap == "pbr_neutral"
    cube = np.array([[[0.1, 0.5, 0.9]]]) * 16.0
    s8 = {op: np.round(color.srgb_encode(tonemap_to_display(cube, tonemap_op=op, exposure=-1.63)) * 255)[0, 0]
          for op in ("pbr_neutral", "reinhard")}
    assert s8["pbr_neutral"].max() < 255 and s8["reinhard"][2] == 255
    lin = color.srgb_decode(s8["pbr_neutral"] / 255.0)
    assert lin.min() / lin.max() > 0.4


def test_the_preview_png_is_its_linear_image_through_the_chosen_tone_map(tmp_path):
    h = embedded_gltf({"POSITION": np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)}, np.array([[0, 1, 2]]),
                      {"pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.3, 0.1, 1.0], "metallicFactor": 0.0}})
    path = tmp_path / "t.gltf"
    path.write_text(json.dumps(h))
    for op in ("pbr_neutral", "aces"):
        ps = PreviewScene(load_asset(path), PreviewOptions(width=24, height=18, spp=1, tonemap=op))
        try:
            img = ps.render_view(ps.azimuth).image
            expect = tonemap_to_display(img, tonemap_op=op, exposure=ps.exposure)
            np.testing.assert_array_equal(ps.to_display(img), np.round(color.srgb_encode(expect) * 255))
        finally:
            ps.close()
