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


def test_gltf_extras_keep_a_material_off_the_compiled_path():
    """A glTF material with occlusion, emission or a normal map has no compiled record (the kernel would drop them;
    an occlusion texture made the compiled path's record evaluate it on a one-hit context and crash the previewer on
    TextureTransformMultiTest); without extras it keeps its base model's record."""
    from pyrt.io.assets.materials import GltfMaterial
    from pyrt.textures.procedural import CheckerTexture

    def pack(tex):
        return None

    plain = GltfMaterial(base_color=0.5, metallic=0.0, roughness=0.5)
    assert plain.compiled_record(pack) is not None
    occluded = GltfMaterial(base_color=0.5, metallic=0.0, roughness=0.5, occlusion=CheckerTexture(0.2, 1.0))
    assert occluded.compiled_record(pack) is None
    glowing = GltfMaterial(base_color=0.5, metallic=0.0, roughness=0.5, emission=(1.0, 0.5, 0.2))
    assert glowing.compiled_record(pack) is None
