"""Light-probe mappings (issue 16, item 6): angular map and mirror ball, direction <-> texel round trips."""
import numpy as np
import pytest

from pyrt.lights import ENVIRONMENTS, AngularMapEnvironment, MirrorBallEnvironment, procedural_sky
from pyrt.shaders import probes as P
from pyrt.shaders import sampling


def _dirs(rng, n=5000):
    d = sampling.square_to_uniform_sphere(rng.random((n, 2)))
    return d[d[:, 2] < 0.999]          # away from +z, the rim point (singular for both maps)


@pytest.mark.parametrize("kind", P.PROBE_KINDS)
def test_dir_uv_dir_round_trip(kind, rng):
    to_uv, to_dir, _ = P.PROBE_MAPPINGS[kind]
    d = _dirs(rng)
    uv = to_uv(d)
    assert np.all(np.hypot(2 * uv[:, 0] - 1, 2 * uv[:, 1] - 1) <= 1 + 1e-12)
    np.testing.assert_allclose(to_dir(uv), d, atol=1e-9)


@pytest.mark.parametrize("kind", P.PROBE_KINDS)
def test_uv_dir_uv_round_trip_inside_the_disc(kind, rng):
    to_uv, to_dir, _ = P.PROBE_MAPPINGS[kind]
    uv = rng.random((5000, 2))
    uv = uv[np.hypot(2 * uv[:, 0] - 1, 2 * uv[:, 1] - 1) < 0.999]
    d = to_dir(uv)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(to_uv(d), uv, atol=1e-9)


def test_angular_map_closed_form_spot_values():
    # centre -z, rim +z; +x at 90 degrees from -z: r = (pi/2) / pi = 1/2 -> u = 0.75
    d = np.array([[0, 0, -1.0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0], [np.sqrt(0.5), 0, -np.sqrt(0.5)]])
    uv = P.angular_dir_to_uv(d)
    np.testing.assert_allclose(uv, [[0.5, 0.5], [0.75, 0.5], [0.5, 0.75], [1.0, 0.5], [0.625, 0.5]], atol=1e-12)
    # the brief's formula r = acos(-z) / (pi sqrt(x^2 + y^2)), (u, v) = (0.5 + x r / 2, 0.5 + y r / 2)
    rng = np.random.default_rng(3)
    q = _dirs(rng, 100)
    r = np.arccos(-q[:, 2]) / (np.pi * np.hypot(q[:, 0], q[:, 1]))
    np.testing.assert_allclose(P.angular_dir_to_uv(q), np.stack([0.5 + q[:, 0] * r / 2, 0.5 + q[:, 1] * r / 2], 1),
                               atol=1e-12)


def test_mirror_ball_closed_form_spot_values():
    # rho = sin(theta / 2), theta from -z: +x (90 deg) -> rho = sqrt(1/2); and it is the reflection off
    # the ball's normal n = (a, b, -sqrt(1 - rho^2)) of the view ray along +z
    d = np.array([[0, 0, -1.0], [1, 0, 0], [0, -1, 0]])
    uv = P.mirror_ball_dir_to_uv(d)
    s = np.sqrt(0.5)
    np.testing.assert_allclose(uv, [[0.5, 0.5], [0.5 + s / 2, 0.5], [0.5, 0.5 - s / 2]], atol=1e-12)
    a, b = 2 * uv[:, 0] - 1, 2 * uv[:, 1] - 1
    n = np.stack([a, b, -np.sqrt(1 - a * a - b * b)], 1)
    view = np.array([0, 0, 1.0])                       # camera at -z looking along +z
    refl = view - 2 * (n @ view)[:, None] * n
    np.testing.assert_allclose(refl, d, atol=1e-12)


@pytest.mark.parametrize("kind", P.PROBE_KINDS)
def test_texel_solid_angles_sum_to_4pi(kind):
    # midpoint rule on a 4x4 sub-grid per texel; error from the rim texels, measured < 0.5 % at 64^2
    om = P.probe_texel_solid_angle(kind, 64)
    np.testing.assert_allclose(om.sum(), 4 * np.pi, rtol=5e-3)


@pytest.mark.parametrize("cls", [AngularMapEnvironment, MirrorBallEnvironment])
def test_probe_environment_reproduces_the_latlong_it_was_made_from(cls, rng):
    sky = procedural_sky(128, 64, sun_angle=20.0)
    from pyrt.lights import LatLongEnvironment
    ll = LatLongEnvironment(sky, filter="bilinear")
    env = cls(cls.from_latlong_image(sky, 256))
    d = _dirs(rng, 2000)
    d = d[d[:, 2] < 0.5]                      # the mirror ball squeezes +z into the rim
    a, b = env.radiance(d), ll.radiance(d)
    assert np.median(np.abs(a - b) / (b + 1e-3)) < 0.05
    assert ENVIRONMENTS[cls.type_name] is cls


def test_probe_must_be_square():
    from pyrt.lights import EnvironmentMapError
    with pytest.raises(EnvironmentMapError, match="square"):
        AngularMapEnvironment(np.ones((8, 16, 3)))
