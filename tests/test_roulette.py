"""Russian roulette below the throughput cutoff (``roulette=True``, :mod:`pyrt.integrators.roulette`): a ray whose
throughput falls below ``throughput_cutoff`` goes on with probability ``max_c t_c / cutoff``, its throughput divided
by it, so the expected image is the one without a cutoff (unbiased), where dropping it loses the light it carries."""
import numpy as np
import pytest

import pyrt
from pyrt.integrators.roulette import survivors


def test_survivors_keep_the_expected_throughput_and_leave_rays_above_the_cutoff_alone(rng):
    n = 200_000
    t = np.empty((n, 3))
    t[:, 0] = rng.uniform(0.0, 0.02, n)             # below and above the cutoff 0.01
    t[:, 1] = 0.5 * t[:, 0]
    t[:, 2] = 0.0
    alive0, t0 = survivors(t, 0.01)                 # no generator: dropped
    np.testing.assert_array_equal(alive0, t[:, 0] > 0.01)
    assert t0 is t
    alive, t1 = survivors(t, 0.01, np.random.default_rng(7))
    above = t[:, 0] > 0.01
    np.testing.assert_array_equal(t1[above], t[above])
    low = ~above
    assert np.all(alive[above]) and 0 < alive[low].sum() < low.sum()
    np.testing.assert_allclose(t1[low & alive, 0], 0.01, rtol=1e-12)   # survivors lifted back to the cutoff
    np.testing.assert_allclose(t1[low & alive, 1] / t1[low & alive, 0], 0.5, rtol=1e-12)   # the colour kept
    kept = np.where(alive[:, None], t1, 0.0)[low].sum(axis=0)         # the sum over the low rays: unbiased
    expect = t[low].sum(axis=0)
    se = 0.01 * np.sqrt(low.sum() * 0.25)           # Bernoulli(q) x cutoff: sd <= cutoff / 2 per ray
    assert abs(kept[0] - expect[0]) < 5 * se
    assert not survivors(np.zeros((4, 3)), 0.01, np.random.default_rng(1))[0].any()


def _mirror_scene(reflectance):
    """A mirror filling the view reflects a constant background of radiance 1: the image is ``reflectance``."""
    cam = pyrt.Camera(position=(0, 1, 0), target=(0, 0, 0), up=(0, 0, -1), fov=40.0, width=32, height=32, spp=4)
    scene = pyrt.Scene(cam, background=(1.0, 1.0, 1.0))
    scene.add_plane((0, 0, 0), 10.0, pyrt.Mirror(reflectance=reflectance))
    return scene


@pytest.mark.parametrize("backend", ["numpy", "compiled"])
@pytest.mark.parametrize("integrator", ["whitted", "glossy"])
def test_a_mirror_below_the_cutoff_keeps_its_light_with_roulette_and_loses_it_without(integrator, backend):
    """Reflectance 0.004 under throughput_cutoff 0.01: dropped, the image is black (the bias roulette removes); with
    roulette each sample is 0 or 0.01 and the mean over 4096 samples is 0.004 within 5 standard errors (both
    paths)."""
    r = np.array([0.004, 0.002, 0.001])
    scene = _mirror_scene(r)
    assert pyrt.render(scene, throughput_cutoff=0.01, integrator=integrator, backend=backend).max() == 0.0
    res = pyrt.render_full(scene, throughput_cutoff=0.01, roulette=True, integrator=integrator, seed=3,
                           backend=backend)
    img = res.image.reshape(-1, 3)
    n = img.shape[0] * 4
    q = r[0] / 0.01
    se = 0.01 * np.sqrt(q * (1 - q) / n) * r / r[0]
    assert np.all(np.abs(img.mean(axis=0) - r) < 5 * se), (img.mean(axis=0), r, se)
    assert 0 < np.count_nonzero(img[:, 0]) < img.shape[0]
    assert res.stats.backend == backend
    np.testing.assert_array_equal(pyrt.render(scene, throughput_cutoff=0.01, roulette=True, integrator=integrator,
                                              seed=3, backend=backend), res.image)        # same seed, same image


def test_roulette_above_the_cutoff_changes_nothing():
    scene = _mirror_scene(0.5)
    np.testing.assert_array_equal(pyrt.render(scene, roulette=True, backend="numpy", seed=1),
                                  pyrt.render(scene, backend="numpy", seed=1))


def test_roulette_must_be_a_boolean_in_the_api_and_in_scene_files(tmp_path):
    with pytest.raises(pyrt.Error, match="roulette must be True or False, got 'yes'"):
        pyrt.render(_mirror_scene(0.5), roulette="yes")
    f = tmp_path / "s.toml"
    f.write_text('[camera]\nwidth = 4\nheight = 4\n[render]\nroulette = "yes"\n')
    with pytest.raises(pyrt.Error, match=r"s.toml: \[render\] roulette must be true or false, got 'yes'"):
        pyrt.load_scene(str(f))
    f.write_text('[camera]\nwidth = 4\nheight = 4\n[render.integrator]\nroulette = true\n')
    assert pyrt.load_scene(str(f))[1]["integrator"]["roulette"] is True
