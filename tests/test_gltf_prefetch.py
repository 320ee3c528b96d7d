"""glTF images are decoded on a thread pool before the materials read them (GltfFile.prefetch_images): the same
textures, the same substitution notes and the same errors as decoding them one by one as the slots ask."""
import json
import threading

import numpy as np
import pytest
import trimesh
from PIL import Image
from trimesh.visual.material import PBRMaterial

from pyrt.io.assets import AssetError, load_asset
from pyrt.io.assets import gltf_file


def _multi_image_gltf(tmp_path, rng, n=4):
    """A .gltf box with ``n`` materials, each reading its own PNG (baseColorTexture) and the last image also as a
    normal map and an emissive map; image 1's URI is in another case than its file."""
    box = trimesh.creation.box()
    box.visual = trimesh.visual.TextureVisuals(uv=np.full((8, 2), 0.5), material=PBRMaterial(
        baseColorTexture=Image.fromarray(np.zeros((2, 2, 3), np.uint8))))
    files = trimesh.Scene(box).export(file_type="gltf")
    header = json.loads(files["model.gltf"])
    for name, data in files.items():
        if name != "model.gltf":
            (tmp_path / name).write_bytes(data)
    pixels = []
    for i in range(n):
        px = rng.integers(0, 256, (6 + i, 5, 3), dtype=np.uint8)
        Image.fromarray(px).save(tmp_path / f"img{i}.png")
        pixels.append(px)
    header["images"] = [{"uri": f"img{i}.png" if i != 1 else "IMG1.png"} for i in range(n)]
    header["textures"] = [{"source": i} for i in range(n)]
    header["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": i}}} for i in range(n)]
    header["materials"][-1].update(normalTexture={"index": n - 1}, emissiveTexture={"index": n - 1},
                                   emissiveFactor=[1, 1, 1])
    path = tmp_path / "model.gltf"
    path.write_text(json.dumps(header))
    return str(path), pixels


def _no_prefetch(monkeypatch):
    monkeypatch.setattr(gltf_file.GltfFile, "prefetch_images", lambda self, indices, workers=None: None)


def _decode_threads(monkeypatch):
    """Record the thread of every image decode."""
    seen = []
    orig = gltf_file.GltfFile._decode

    def spy(self, ii, source=None):
        seen.append((ii, threading.current_thread() is threading.main_thread()))
        return orig(self, ii, source)
    monkeypatch.setattr(gltf_file.GltfFile, "_decode", spy)
    return seen


def _textures(asset):
    out = []
    for m in asset.materials:
        for slot in (m.base_color_texture, m.normal_texture, m.emissive_texture):
            out.append(None if slot is None else np.array(getattr(slot, "texture", slot).image))
    return out


def test_prefetched_images_give_the_same_textures_and_notes(tmp_path, rng, monkeypatch):
    path, pixels = _multi_image_gltf(tmp_path, rng)
    seen = _decode_threads(monkeypatch)
    a = load_asset(path)
    assert sorted(ii for ii, main in seen if not main) == [0, 2, 3]   # the relocated file is left to the slot
    assert sorted(ii for ii, main in seen if main) == [1]             # each image decoded once
    with monkeypatch.context() as m:
        _no_prefetch(m)
        b = load_asset(path)
    for x, y in zip(_textures(a), _textures(b), strict=True):
        assert (x is None) == (y is None)
        if x is not None:
            np.testing.assert_array_equal(x, y)
    assert a.substitutions == b.substitutions and len(a.substitutions) == 1 and "IMG1.png" in a.substitutions[0]
    assert a.warnings == b.warnings


def test_a_broken_image_is_reported_by_its_slot_as_without_prefetching(tmp_path, rng, monkeypatch):
    path, _ = _multi_image_gltf(tmp_path, rng)
    (tmp_path / "img2.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 30)
    with pytest.raises(AssetError) as with_prefetch:
        load_asset(path)
    _no_prefetch(monkeypatch)
    with pytest.raises(AssetError) as without:
        load_asset(path)
    assert str(with_prefetch.value) == str(without.value)
    assert "image 2 (img2.png)" in str(without.value) and "not a readable PNG" in str(without.value)


def test_images_over_the_texture_budget_are_not_prefetched(tmp_path, rng, monkeypatch):
    """An image the budget reduces is decoded by its slot (whole images of every slot at once would raise the
    peak memory); the others still are prefetched."""
    path, _ = _multi_image_gltf(tmp_path, rng, n=5)
    Image.fromarray(rng.integers(0, 256, (64, 64, 3), dtype=np.uint8)).save(tmp_path / "img4.png")
    seen = _decode_threads(monkeypatch)
    a = load_asset(path, max_texture=16)
    assert sorted(ii for ii, main in seen if not main) == [0, 2, 3]
    assert {ii for ii, main in seen if main} == {1, 4}      # 4: once per decoding (colour and normal slots)
    assert a.materials[4].base_color_texture.texture.image.shape[:2] == (16, 16)


def test_a_malformed_image_entry_is_reported_as_without_prefetching(tmp_path, rng, monkeypatch):
    path, _ = _multi_image_gltf(tmp_path, rng)
    header = json.loads(open(path).read())
    header["images"][2] = 5                                   # not an object
    with open(path, "w") as fh:
        json.dump(header, fh)
    with pytest.raises(AssetError) as with_prefetch:
        load_asset(path)
    _no_prefetch(monkeypatch)
    with pytest.raises(AssetError) as without:
        load_asset(path)
    assert str(with_prefetch.value) == str(without.value) and "images[2] must be an object" in str(without.value)
