"""OBJ/MTL dissolve (``d``, ``Tr``, ``map_d``) as coverage, glass only for the glass illumination models."""
import numpy as np
import pytest
from PIL import Image

import pyrt
from pyrt.io.assets import load_asset
from pyrt.io.assets import materials as A
from pyrt.io.assets.materials import ScaledTexture

OBJ = """mtllib m.mtl
v -1 -1 0
v 1 -1 0
v 1 1 0
v -1 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
usemtl {mat}
f 1/1 2/2 3/3
f 1/1 3/3 4/4
"""


def _mats(tmp_path, mtl, mat="m", images=()):
    (tmp_path / "m.mtl").write_text(mtl)
    (tmp_path / "m.obj").write_text(OBJ.format(mat=mat))
    for name, arr in images:
        Image.fromarray(arr).save(tmp_path / name)
    asset = load_asset(str(tmp_path / "m.obj"))
    return asset, {p.name: A.to_pyrt_material(p) for p in asset.materials}


def test_d_and_tr_are_dissolve_not_glass(tmp_path):
    _, mats = _mats(tmp_path, "newmtl m\nKd 0.5 0.5 0.5\nd 0.4\nnewmtl t\nKd 1 0 0\nTr 0.25\n"
                              "newmtl g\nKd 1 1 1\nd 0.2\nNi 1.4\nillum 7\nnewmtl o\nKd 1 1 1\nd 1\n")
    assert isinstance(mats["m"], A.ObjMaterial) and mats["m"].alpha_mode == "blend" and mats["m"].opacity == 0.4
    assert mats["t"].alpha_mode == "blend" and mats["t"].opacity == pytest.approx(0.75)
    assert isinstance(mats["g"], pyrt.Glass) and mats["g"].ior == 1.4
    assert mats["o"].alpha_mode == "opaque"


def test_map_d_channels(tmp_path):
    rgba = np.zeros((4, 4, 4), np.uint8)
    rgba[..., 0] = 255
    rgba[:, 2:, 3] = 255                                   # alpha: left half 0, right half 1
    grey = np.full((4, 4), 51, np.uint8)                   # 0.2
    mtl = ("newmtl a\nKd 1 1 1\nmap_d cut.png\n"
           "newmtl r\nKd 1 1 1\nmap_d -imfchan r cut.png\n"
           "newmtl g\nKd 1 1 1\nd 0.5\nmap_d grey.png\n")
    _, mats = _mats(tmp_path, mtl, mat="a", images=[("cut.png", rgba), ("grey.png", grey)])
    ctx = pyrt.geometry.SurfaceBatch(p=np.zeros((2, 3)), uv=np.array([[0.3, 0.5], [0.7, 0.5]]),
                                     duvdx=np.zeros((2, 2)), duvdy=np.zeros((2, 2)))
    np.testing.assert_allclose(mats["a"].coverage(ctx), [0.0, 1.0], atol=1e-6)   # the alpha channel
    np.testing.assert_allclose(mats["r"].coverage(ctx), [1.0, 1.0], atol=1e-6)   # red, as asked
    assert isinstance(mats["g"].opacity, ScaledTexture)
    np.testing.assert_allclose(mats["g"].coverage(ctx), [0.1, 0.1], atol=1e-6)   # 0.5 x grey 0.2
    assert all(m.alpha_mode == "blend" for m in mats.values())


def test_map_d_errors_and_missing_file(tmp_path):
    _, mats = _mats(tmp_path, "newmtl m\nKd 1 1 1\nmap_d nothere.png\n")
    assert mats["m"].alpha_mode == "opaque"                # the factor alone (d = 1): a substitution
    asset, _ = _mats(tmp_path, "newmtl m\nKd 1 1 1\nmap_d nothere.png\n")
    assert any("map_d" in s and "nothere.png" in s for s in asset.substitutions)
    grey = np.full((4, 4), 51, np.uint8)
    with pytest.raises(pyrt.Error, match=r"map_d.*-imfchan g but the image has 1 channel"):
        _mats(tmp_path, "newmtl m\nKd 1 1 1\nmap_d -imfchan g grey.png\n", images=[("grey.png", grey)])


def test_dissolve_renders_as_coverage(tmp_path):
    """A quad whose left half has map_d alpha 0 in front of the camera: those pixels are exactly the background,
    the right half is the (unlit, emissive) surface."""
    rgba = np.zeros((64, 64, 4), np.uint8)
    rgba[:, 32:, 3] = 255                                  # u < 0.5 transparent
    asset, _ = _mats(tmp_path, "newmtl m\nKd 0 0 0\nKs 0 0 0\nKe 1 1 1\nmap_d cut.png\n",
                     images=[("cut.png", rgba)])
    cam = pyrt.Camera(position=(0, 0, 3), target=(0, 0, 0), fov=20, width=16, height=8, jitter=False)
    sc = pyrt.Scene(cam, background=(0.2, 0.3, 0.4))
    asset.add_to_scene(sc, lights=False)
    img = pyrt.render(sc, spp=1)
    left, right = img[:, 1:6], img[:, 10:15]              # column 0 and 15 see past the quad
    np.testing.assert_allclose(left.reshape(-1, 3), np.tile([0.2, 0.3, 0.4], (left.size // 3, 1)), atol=1e-6)
    np.testing.assert_allclose(right, 1.0, atol=1e-6)
