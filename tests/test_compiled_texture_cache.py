"""The compiled texture table is packed once per prepared scene while its textures' lookups stay the same
(:func:`pyrt.integrators.compiled.texture_table`), and packed again when they change."""
import numpy as np

import pyrt
from pyrt.integrators import compiled


def _scene(tex):
    cam = pyrt.Camera(position=(0, 1.5, 3.0), target=(0, 0, 0), fov=40, width=24, height=18, spp=1, jitter=False)
    s = pyrt.Scene(cam, background=0.1)
    s.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=tex))
    s.add_light(pyrt.PointLight((1, 2, 1), intensity=8.0))
    return s


def _texture(seed):
    img = np.random.default_rng(seed).random((32, 32, 3)).astype(np.float32)
    return pyrt.ImageTexture(img, filter="trilinear")


def test_a_prepared_scene_packs_its_texture_table_once():
    s = _scene(_texture(1))
    ex = dict(progress=False, backend="compiled")
    with pyrt.PreparedScene(s) as ps:
        a = pyrt.render_full(s, seed=0, execution=pyrt.Execution(prepared=ps, **ex))
        table = ps.compiled_textures[1]
        b = pyrt.render_full(s, seed=0, execution=pyrt.Execution(prepared=ps, **ex))
        assert ps.compiled_textures[1] is table                  # reused: the same arrays
        np.testing.assert_array_equal(a.image, b.image)
        s.materials[0].albedo_value = _texture(2)                  # another texture: packed again
        c = pyrt.render_full(s, seed=0, execution=pyrt.Execution(prepared=ps, **ex))
        assert ps.compiled_textures[1] is not table
    fresh = pyrt.render_full(s, seed=0, execution=pyrt.Execution(**ex))
    np.testing.assert_array_equal(c.image, fresh.image)
    assert not np.array_equal(a.image, c.image)


def test_texture_key_is_none_for_texels_of_other_textures():
    packer = compiled._TexturePacker()
    packer.add(_texture(3))
    key = compiled._texture_key(packer)
    assert key is not None and key == compiled._texture_key(packer)
    packer.objects[0] = object()                                   # texels from something else: not cached
    assert compiled._texture_key(packer) is None
