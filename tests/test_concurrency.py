"""Renders in parallel threads of one process give the same images as one at a time (bit-identical)."""
from concurrent.futures import ThreadPoolExecutor

import numpy as np

import pyrt


def _scene(kind):
    cam = pyrt.Camera(position=(0, 1.5, 4), target=(0, 0.4, 0), width=48, height=36, spp=4)
    s = pyrt.Scene(cam)
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(pyrt.CheckerTexture(0.2, 0.8)), name="floor")
    if kind == "glass":
        s.add_sphere((0, 0.6, 0), 0.6, pyrt.Glass(1.5), name="ball")
        s.add_sphere((0.9, 0.3, -0.8), 0.3, pyrt.Mirror(0.9), name="chrome")
        s.add_light(pyrt.PointLight((2, 3, 2), intensity=30.0))
    else:
        s.add_sphere((0, 0.6, 0), 0.6, pyrt.CookTorrance(kd=0.3, ks=0.6, roughness=0.4), name="ball")
        pyrt.RectLight((0, 2.5, 0), size=1.0, power=40.0, n_samples=4).add_to(s)
        pyrt.set_environment(s, pyrt.ConstantEnvironment(0.2), lighting="mis")
    return s


def test_parallel_renders_match_serial_ones():
    scenes = [_scene("glass"), _scene("area")]
    serial = [pyrt.render(s, seed=7) for s in scenes]
    # two different scenes at once, and the same Scene object twice at once, each itself multi-threaded
    jobs = [scenes[0], scenes[1], scenes[0], scenes[1], scenes[0]]
    with ThreadPoolExecutor(max_workers=len(jobs)) as pool:
        parallel = list(pool.map(lambda s: pyrt.render(s, seed=7), jobs))
    for s, img in zip(jobs, parallel):
        assert np.array_equal(img, serial[scenes.index(s)])


def test_one_prepared_scene_shared_by_parallel_renders():
    s = _scene("area")
    ref = pyrt.render(s, seed=3)
    with pyrt.PreparedScene(s) as ps, ThreadPoolExecutor(max_workers=3) as pool:
        imgs = list(pool.map(lambda _: pyrt.render(s, seed=3, prepared=ps), range(3)))
    assert all(np.array_equal(i, ref) for i in imgs)
