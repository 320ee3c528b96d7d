"""The Whitted loop's hit order: camera hits are ordered by material (Integrator._by_material) so that material
groups are slices; the image must not depend on that order."""
import numpy as np

import pyrt
from pyrt.integrators.whitted import Integrator


def _two_materials_per_row():
    # the left half of every image row sees material 0, the right half material 1 (no misses): in ray order the
    # hits alternate between the materials row by row, the first ray hits material 0 and the last material 1
    cam = pyrt.Camera(position=(0, 0, 3), target=(0, 0, 0), fov=40, width=24, height=16, spp=1)
    s = pyrt.Scene(cam)
    s.add_plane((-2, 0, 0), 4.0, pyrt.Lambert(albedo=(0.9, 0.2, 0.1)), normal=(0, 0, 1))
    s.add_plane((2, 0, 0), 4.0, pyrt.BlinnPhong(kd=(0.1, 0.3, 0.8), ks=0.2, exponent=30), normal=(0, 0, 1))
    s.add_light(pyrt.PointLight((0.5, 1.0, 2.0), intensity=5))
    return s


def test_image_does_not_depend_on_the_hit_order(monkeypatch):
    scene = _two_materials_per_row()
    sorted_img = pyrt.render(scene, seed=0, progress=False, threads=1)
    assert np.all(sorted_img.max(axis=2) > 0), "every pixel should see a lit plane"
    # hits left in ray order: the direct-light pass reorders them by material itself (a permutation of a
    # contiguous run, which must not be mistaken for the run itself)
    monkeypatch.setattr(Integrator, "_by_material", lambda self, h, hits: (h, hits))
    ray_order_img = pyrt.render(scene, seed=0, progress=False, threads=1)
    assert np.array_equal(sorted_img, ray_order_img)
