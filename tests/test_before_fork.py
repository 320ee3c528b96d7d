"""Before render workers are forked, the scene's MIP pyramids are built once (PreparedScene.before_fork), so the
workers share them: every image texture of the materials is found, whatever holds it, and built whole."""
import numpy as np

import pyrt
from pyrt.integrators.prepared import image_textures
from pyrt.textures.image import ImageTexture
from pyrt.textures.normal_map import NormalMap


def _scene(rng):
    cam = pyrt.Camera(position=(0, 2, 3), target=(0, 0, 0), fov=45, width=64, height=48, spp=8)
    s = pyrt.Scene(cam)
    base = ImageTexture(rng.random((64, 64, 3)).astype(np.float32))
    rough = ImageTexture(rng.random((32, 32)).astype(np.float32), filter="bilinear")   # reads level 0 only
    mat = pyrt.CookTorrance(kd=base, ks=0.5, roughness=0.4)
    mat.normal_map = NormalMap(np.full((16, 16, 3), 0.5, np.float32) + [0, 0, 0.5], filter="trilinear")
    s.add_plane((0, 0, 0), 4.0, mat, name="floor")
    s.add_sphere((0, 0.5, 0), 0.5, pyrt.Lambert(albedo=base), name="ball")   # the same texture again
    s.add_light(pyrt.PointLight((1, 3, 1), intensity=20))
    return s, base, rough, mat.normal_map


def test_image_textures_finds_each_texture_once(rng):
    s, base, rough, nmap = _scene(rng)
    found = image_textures(*s.materials)
    assert sorted(map(id, found)) == sorted(map(id, [base, nmap]))
    holder = pyrt.Lambert(albedo=0.5)
    holder.extra = {"maps": [rough, (base,)]}
    assert sorted(map(id, image_textures(holder))) == sorted(map(id, [rough, base]))


def test_before_fork_builds_every_level_of_mipmapped_textures_once(rng):
    s, base, rough, nmap = _scene(rng)
    ps = pyrt.PreparedScene(s)
    assert base.mip_levels_built == []
    ps.before_fork()
    assert base.mip_levels_built == list(range(1, 7)) and nmap.mip_levels_built == list(range(1, 5))
    assert "mip_levels" in ps.timings
    ps.close()


def test_a_process_render_builds_them_in_the_parent_and_equals_threads(rng):
    s, base, rough, nmap = _scene(rng)
    a = pyrt.render(s, seed=1, threads=2, parallel="threads", chunk_samples=2048)
    assert len(base.mip_levels_built) < 6                # lazily: only what the lookups read
    b = pyrt.render(s, seed=1, threads=2, parallel="processes", chunk_samples=2048)
    np.testing.assert_array_equal(a, b)
    assert base.mip_levels_built == list(range(1, 7))    # built before the fork, in this process


def test_levels_built_on_threads_equal_levels_built_one_by_one(rng):
    """before_fork builds the pyramids on a thread per texture: the same levels as building them in turn, a
    pyramid that two textures share included (it builds under its lock, once)."""
    coded = (rng.random((64, 48, 3)) * 255).astype(np.uint8)
    shared = ImageTexture(coded)
    twin = ImageTexture(shared, wrap="clamp")            # the same texels and lazy pyramid, its own sampler
    others = [ImageTexture(rng.random((32, 40, 3)).astype(np.float32)) for _ in range(3)]
    s = pyrt.Scene(pyrt.Camera(width=8, height=6))
    for k, tex in enumerate([shared, twin] + others):
        s.add_sphere((3.0 * k, 0.0, 0.0), 1.0, pyrt.Lambert(albedo=tex), subdivisions=1)
    ps = pyrt.PreparedScene(s)
    ps.before_fork()
    for tex in [shared] + others:
        fresh = ImageTexture(tex.image if tex is not shared else coded)
        fresh.build_mip_levels()
        assert tex.mip_levels_built == fresh.mip_levels_built
        for lev in tex.mip_levels_built:
            np.testing.assert_array_equal(tex._pyramid[lev], fresh._pyramid[lev])
    assert twin.mip_levels_built == shared.mip_levels_built
    ps.close()
