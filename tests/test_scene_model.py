"""tools/make_scene_model.py: the Sponza-like benchmark scene loads as written (parts, materials, textures, the
alpha-masked ones) and its masked parts' holes are cut where their alpha is 0."""
import os
import sys

import numpy as np

from pyrt.io.assets import load_asset

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tools"))
import make_scene_model  # noqa: E402  (the generator of tools/make_scene_model.py)


def test_scene_model_loads_with_its_materials_and_masks(tmp_path):
    path = str(tmp_path / "scene.glb")
    n_tri, n_mat, n_tex = make_scene_model.make_scene(path, parts=4, size=32, rings=6, segments=8, mask_every=2)
    assert (n_mat, n_tex) == (4, 12)
    asset = load_asset(path)
    assert asset.n_triangles == n_tri
    assert len(asset.materials) == 4
    modes = [m.alpha_mode for m in asset.materials]
    assert modes == ["OPAQUE", "MASK", "OPAQUE", "MASK"]


def test_holes_are_round_and_cover_part_of_the_image():
    a = make_scene_model.holes(96, seed=1)
    assert a.dtype == np.uint8 and set(np.unique(a)) == {0, 255}
    frac = np.mean(a == 0)
    # 12 x 12 holes of radius sqrt(0.08) cells: pi * 0.08 of every cell
    assert abs(frac - np.pi * 0.08) < 0.03
