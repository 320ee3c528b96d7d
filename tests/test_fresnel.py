"""Fresnel forms (shaders/fresnel.py) and the metal table (shaders/metals.py)."""
import numpy as np
import pytest

from pyrt.shaders import fresnel
from pyrt.shaders import metals


@pytest.mark.parametrize("eta", [1.2, 1.33, 1.5, 2.42])
def test_dielectric_normal_incidence_matches_closed_form(eta):
    R = fresnel.fr_dielectric(np.array([1.0]), eta)[0]
    assert R == pytest.approx(((eta - 1) / (eta + 1)) ** 2, rel=1e-12)


@pytest.mark.parametrize("eta", [1.33, 1.5, 2.42])
def test_dielectric_goes_to_one_at_grazing(eta):
    cos = np.array([1e-3, 1e-5, 0.0])
    R = fresnel.fr_dielectric(cos, eta)
    assert np.all(np.diff(R) >= 0) and R[-1] == pytest.approx(1.0, abs=1e-12)
    assert R[0] > 0.98  # 1e-3 from grazing


def test_dielectric_brewster_angle_p_reflectance_zero():
    # at Brewster's angle tan(theta_B) = eta the p-polarised part vanishes: R = r_perp^2 / 2
    eta = 1.5
    tb = np.arctan(eta)
    ci = np.cos(tb)
    ct = np.sqrt(1 - np.sin(tb) ** 2 / eta ** 2)
    r_perp = (ci - eta * ct) / (ci + eta * ct)
    assert fresnel.fr_dielectric(np.array([ci]), eta)[0] == pytest.approx(0.5 * r_perp ** 2, rel=1e-12)


@pytest.mark.parametrize("eta,k", [(0.37, 2.82), (0.177, 3.638), (0.617, 2.63), (2.485, 3.433), (1.5, 0.0)])
def test_conductor_normal_incidence_matches_closed_form(eta, k):
    R = fresnel.fr_conductor(np.array([1.0]), np.full(3, eta), np.full(3, k))[0]
    expect = ((eta - 1) ** 2 + k ** 2) / ((eta + 1) ** 2 + k ** 2)
    np.testing.assert_allclose(R, expect, rtol=1e-12)


def test_conductor_with_k_zero_is_the_dielectric():
    cos = np.linspace(0, 1, 101)
    for eta in (1.33, 1.5, 2.0):
        Rc = fresnel.fr_conductor(cos, np.full(3, eta), np.zeros(3))[:, 0]
        np.testing.assert_allclose(Rc, fresnel.fr_dielectric(cos, eta), atol=1e-12)


def test_conductor_grazing_is_one_and_range():
    cos = np.linspace(0, 1, 201)
    R = fresnel.fr_conductor(cos, np.array([0.2, 0.9, 1.6]), np.array([3.0, 2.5, 1.7]))
    assert np.all((R >= 0) & (R <= 1))
    np.testing.assert_allclose(R[0], 1.0, atol=1e-12)


def test_conductor_against_course_approximation_at_normal_incidence_only():
    # the course's closed form (r^2 with eta^2 + k^2) is exact at normal incidence
    eta, k = 0.37, 2.82
    c = 1.0
    a = eta * eta + k * k
    rpar = (a * c * c - 2 * eta * c + 1) / (a * c * c + 2 * eta * c + 1)
    rperp = (a - 2 * eta * c + c * c) / (a + 2 * eta * c + c * c)
    R = fresnel.fr_conductor(np.array([c]), np.full(3, eta), np.full(3, k))[0, 0]
    assert R == pytest.approx(0.5 * (rpar + rperp), rel=1e-12)


def test_schlick_endpoints():
    f0 = np.array([0.04, 0.5, 0.9])
    np.testing.assert_allclose(fresnel.fr_schlick(np.array([1.0]), f0)[0], f0)
    np.testing.assert_allclose(fresnel.fr_schlick(np.array([0.0]), f0)[0], 1.0)


#: measured max |Schlick - exact| over theta in [0, 90) deg (outside of the dielectric); the test
#: asserts these bounds (a regression in either formula moves the difference).
SCHLICK_MAX_ERR = {1.33: 0.0600, 1.5: 0.0357, 2.0: 0.0445, 2.42: 0.0757}


@pytest.mark.parametrize("eta", sorted(SCHLICK_MAX_ERR))
def test_schlick_within_stated_error_of_exact_dielectric(eta):
    cos = np.cos(np.radians(np.linspace(0, 89.999, 20001)))
    exact = fresnel.fr_dielectric(cos, eta)
    approx = fresnel.fr_schlick(cos, fresnel.f0_from_ior(eta))
    err = np.max(np.abs(approx - exact))
    assert err <= SCHLICK_MAX_ERR[eta]
    assert err >= 0.5 * SCHLICK_MAX_ERR[eta]  # the stated bound is tight, not a blanket tolerance


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_fresnel_kernels_keep_dtype(dtype):
    cos = np.linspace(0, 1, 7).astype(dtype)
    assert fresnel.fr_conductor(cos, np.ones(3), np.ones(3)).dtype == dtype
    assert fresnel.fr_schlick(cos, np.full(3, 0.04)).dtype == dtype
    for model, kw in [("schlick", {"f0": (0.04,) * 3}), ("dielectric", {"eta": 1.5}),
                      ("conductor", {"eta": np.ones(3), "k": np.ones(3)}), ("none", {})]:
        out = fresnel.fresnel_rgb(cos, model, **kw)
        assert out.shape == (7, 3) and out.dtype == dtype and np.all(np.isfinite(out))


def test_fresnel_rgb_rejects_unknown_model():
    with pytest.raises(ValueError, match="fresnel model"):
        fresnel.fresnel_rgb(np.ones(2), "exact")


# ----------------------------------------------------------------------------- metal table


@pytest.mark.parametrize("name", ["gold", "silver", "copper", "aluminium"])
def test_metal_table_is_reproduced_by_its_derivation(name):
    eta, k, worst = metals.derive_rgb_eta_k(name)
    t_eta, t_k = metals.METALS[name]
    # compare reflectance (what is seen), not eta/k, which trade off against each other
    cos = np.cos(np.radians(np.linspace(0, 89, 90)))
    np.testing.assert_allclose(fresnel.fr_conductor(cos, t_eta, t_k), fresnel.fr_conductor(cos, eta, k),
                               atol=2e-4)
    assert worst < 0.012  # fit residual vs the spectrally projected reflectance (module docstring)


def test_metal_normal_reflectance_colours():
    one = np.ones(1)
    R = {m: fresnel.fr_conductor(one, *metals.metal_eta_k(m))[0] for m in ("gold", "silver", "copper", "aluminium")}
    # gold and copper are warm (R > G > B), silver and aluminium near-neutral and bright
    for m in ("gold", "copper"):
        assert R[m][0] > R[m][1] > R[m][2]
    for m in ("silver", "aluminium"):
        assert np.ptp(R[m]) < 0.06 and R[m].min() > 0.9
    # stated values (module docstring), 3 decimals
    np.testing.assert_allclose(R["gold"], [0.988, 0.790, 0.336], atol=1e-3)
    np.testing.assert_allclose(R["silver"], [0.970, 0.960, 0.913], atol=1e-3)


def test_white_reflector_projects_to_white():
    np.testing.assert_allclose(metals.reflectance_to_rgb(metals.LAMBDA_NM, np.ones(metals.LAMBDA_NM.size)),
                               1.0, atol=1e-12)


def test_unknown_metal_names_the_known_ones():
    with pytest.raises(KeyError, match="gold"):
        metals.metal_eta_k("unobtainium")
    assert np.array_equal(metals.metal_eta_k("Aluminum")[0], metals.METALS["aluminium"][0])
