"""OBJ + MTL as exporters write them: the PBR extension (Pr, Pm, map_Pr, map_Pm) and tangent-space normal maps
named by map_Bump (Blender's exporter does both)."""
import numpy as np
import pytest
from PIL import Image

import pyrt
from material_helpers import LocalCtx, direction
from pyrt.io import assets as A
from pyrt.io.assets import load_asset
from pyrt.io.assets.obj import looks_like_normal_map

OBJ = """mtllib m.mtl
v 0 0 0
v 1 0 0
v 1 1 0
vt 0 0
vt 1 0
vt 1 1
vn 0 0 1
usemtl m
f 1/1/1 2/2/1 3/3/1
"""


def _load(tmp_path, mtl, images=None):
    (tmp_path / "m.obj").write_text(OBJ)
    (tmp_path / "m.mtl").write_text(mtl)
    for name, arr in (images or {}).items():
        Image.fromarray(np.asarray(arr, np.uint8)).save(tmp_path / name)
    a = load_asset(str(tmp_path / "m.obj"))
    return a, A.to_pyrt_material(a.materials[a.meshes[0].material])


def _f_cos(mat, n=64):
    wo = np.tile(direction(30.0, 10.0), (n, 1))
    wi = np.stack([direction(t, p) for t, p in zip(np.linspace(0, 85, n), np.linspace(0, 300, n))])
    return mat.f_cos(wo, wi, LocalCtx(n))


def test_pbr_mtl_is_the_metallic_roughness_material_of_its_values(tmp_path):
    a, mat = _load(tmp_path, "newmtl m\nKd 0.9 0.6 0.2\nKs 0.5 0.5 0.5\nNs 250\nPr 0.3\nPm 1.0\n")
    assert isinstance(mat, pyrt.MetallicRoughness) and not isinstance(mat, pyrt.BlinnPhong)
    want = pyrt.MetallicRoughness(base_color=(0.9, 0.6, 0.2), metallic=1.0, roughness=0.3)
    np.testing.assert_allclose(_f_cos(mat), _f_cos(want), rtol=1e-12)
    assert not any("Ks scaled" in w for w in a.warnings)        # Ks and Ns are not used by the PBR mapping


def test_pbr_mtl_maps_replace_their_scalars_and_defaults_fill_the_rest(tmp_path):
    grey = np.full((2, 2), 51, np.uint8)                        # 0.2, linear
    _, mat = _load(tmp_path, "newmtl m\nKd 0.5 0.5 0.5\nPr 0.9\nmap_Pr r.png\n", {"r.png": grey})
    assert mat.param(mat.roughness, LocalCtx(1), 1)[0] == pytest.approx(0.2)
    assert mat.metallic == 0.0                                  # Pm absent: a dielectric
    _, mat = _load(tmp_path, "newmtl m\nKd 0.5 0.5 0.5\nPm 1\n")
    assert mat.roughness == 0.5 and mat.metallic == 1.0


def _normal_map_image(tilt=0.0):
    img = np.zeros((4, 4, 3), np.uint8)
    img[...] = (128 + int(tilt * 127), 128, 255)
    return img


def test_map_bump_that_looks_like_a_normal_map_is_the_normal_map_with_bm_as_strength(tmp_path):
    a, mat = _load(tmp_path, "newmtl m\nKd 0.5 0.5 0.5\nmap_Bump -bm 0.5 n.png\n", {"n.png": _normal_map_image(0.2)})
    assert isinstance(mat.normal_map, pyrt.NormalMap) and mat.normal_map.strength == 0.5
    assert any("looks like a tangent-space normal map" in w for w in a.warnings)
    assert not any("-bm" in w for w in a.warnings)


def test_map_bump_height_map_is_ignored_and_norm_wins(tmp_path):
    a, mat = _load(tmp_path, "newmtl m\nKd 0.5 0.5 0.5\nbump h.png\n", {"h.png": np.full((4, 4), 90, np.uint8)})
    assert mat.normal_map is None
    assert any("height (bump) maps are not supported" in w for w in a.warnings)
    a, mat = _load(tmp_path, "newmtl m\nKd 0.5 0.5 0.5\nnorm n.png\nmap_Bump b.png\n",
                   {"n.png": _normal_map_image(), "b.png": _normal_map_image(0.5)})
    assert mat.normal_map is not None and mat.normal_map.name.endswith("n.png")
    assert any("norm gives the material's normal map" in w for w in a.warnings)


def test_normal_map_test_separates_normal_maps_from_height_and_colour_maps():
    assert looks_like_normal_map(_normal_map_image(0.1))
    assert not looks_like_normal_map(np.full((4, 4, 3), 128, np.uint8))          # grey height map
    assert not looks_like_normal_map(np.full((4, 4, 3), (40, 90, 200), np.uint8))  # a blue colour map
    assert not looks_like_normal_map(np.full((4, 4), 200, np.uint8))
