"""Ray differentials are carried only where a texture reads footprints (Texture.needs_footprint,
Material.uses_footprints): vertex colours, merged material colours and unfiltered image lookups do not, and a scene
whose textures are all such renders the same pixels without differentials, sooner."""
import numpy as np
import pytest
import trimesh

import pyrt
from pyrt.apps.preview import PreviewOptions, PreviewScene, render_preview
from pyrt.integrators.prepared import PreparedScene
from pyrt.io.assets import load_asset
from pyrt.io.assets.alpha import OpacityTexture
from pyrt.io.assets.materials import GltfMaterial, ProductTexture, ScaledTexture, VertexColorTexture
from pyrt.materials import Clearcoat, Material, Sheen
from pyrt.textures import (ChannelTexture, CheckerTexture, ConstantTexture, ImageTexture, NormalMap,
                           flat_normal_map)


def _image(filter_):
    return ImageTexture(np.random.default_rng(0).random((8, 8, 3)).astype(np.float32), filter=filter_)


def test_which_textures_read_footprints():
    tri, bil = _image("trilinear"), _image("bilinear")
    assert tri.needs_footprint and _image("anisotropic").needs_footprint
    assert not bil.needs_footprint and not _image("nearest").needs_footprint
    assert not _image("bicubic").needs_footprint
    assert not NormalMap(flat_normal_map()).needs_footprint               # bilinear by default
    assert NormalMap(flat_normal_map(), filter="trilinear").needs_footprint
    assert not ConstantTexture(0.5).needs_footprint and not VertexColorTexture().needs_footprint
    assert CheckerTexture().needs_footprint                               # procedural: may filter
    assert ChannelTexture(tri, 1).needs_footprint and not ChannelTexture(bil, 1).needs_footprint
    assert ScaledTexture(tri, 2.0).needs_footprint and not ScaledTexture(bil, 2.0).needs_footprint
    assert ProductTexture(VertexColorTexture(), tri).needs_footprint
    assert not ProductTexture(VertexColorTexture(), (1.0, 0.5, 0.5)).needs_footprint
    assert not OpacityTexture(1.0, None, VertexColorTexture(1)).needs_footprint
    assert OpacityTexture(1.0, ChannelTexture(tri, 0)).needs_footprint


def test_materials_use_footprints_through_their_textures_and_layers():
    kw = dict(metallic=0.0, roughness=0.5)
    plain = GltfMaterial(base_color=(0.8, 0.8, 0.8), **kw)
    vcol = GltfMaterial(base_color=ProductTexture(VertexColorTexture(), (0.8, 0.8, 0.8)),
                        normal_map=NormalMap(flat_normal_map()), **kw)
    mapped = GltfMaterial(base_color=_image("trilinear"), **kw)
    assert vcol.uses_textures and not vcol.uses_footprints
    assert mapped.uses_footprints and not plain.uses_footprints
    assert Clearcoat(mapped).uses_footprints and not Clearcoat(vcol).uses_footprints
    assert Clearcoat(vcol, roughness=_image("trilinear")).uses_footprints
    assert Sheen(mapped).uses_footprints and not Sheen(vcol, color=_image("nearest")).uses_footprints
    scene = pyrt.Scene(pyrt.Camera(width=8, height=6))
    scene.add_mesh(trimesh.creation.box(), vcol)
    assert not PreparedScene(scene).needs_differentials
    scene.add_mesh(trimesh.creation.box().apply_translation((3, 0, 0)), mapped)
    assert PreparedScene(scene).needs_differentials


@pytest.fixture
def coloured_glb(tmp_path):
    """A glossy vertex-coloured icosphere (COLOR_0) beside a mirror-ish metal box: glossy and delta rays, no texture
    that reads footprints."""
    s = trimesh.creation.icosphere(3)
    s.visual.vertex_colors = (np.random.default_rng(2).random((len(s.vertices), 4)) * 255).astype(np.uint8)
    box = trimesh.creation.box(extents=(0.5, 2.0, 2.0)).apply_translation((1.6, 0.0, 0.0))
    box.visual.material = trimesh.visual.material.PBRMaterial(baseColorFactor=[200, 200, 200, 255],
                                                              metallicFactor=1.0, roughnessFactor=0.1)
    path = tmp_path / "coloured.glb"
    trimesh.Scene([s, box]).export(path)
    return str(path)


def test_renders_without_differentials_give_the_same_pixels(coloured_glb, monkeypatch):
    o = PreviewOptions(width=48, height=36, spp=2, threads=1)
    assert not PreviewScene(load_asset(coloured_glb), o).prepared.needs_differentials
    without = render_preview(coloured_glb, o)
    monkeypatch.setattr(Material, "uses_footprints", property(lambda self: True))     # every material: carried
    assert PreviewScene(load_asset(coloured_glb), o).prepared.needs_differentials
    with_diffs = render_preview(coloured_glb, o)
    np.testing.assert_array_equal(np.asarray(without.images[0]), np.asarray(with_diffs.images[0]))
