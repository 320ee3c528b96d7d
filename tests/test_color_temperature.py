"""CIE 1931 colour matching (analytic fit), Planck, XYZ <-> sRGB, kelvin -> linear sRGB."""
import math

import numpy as np
import pytest

import pyrt
from pyrt.shaders import color as C

# CIE 1931 2-degree observer, tabulated values (CIE 15:2004 table T.4), at wavelengths in nm.
CIE_TABLE = {
    450: (0.33620, 0.03800, 1.77211),
    500: (0.00490, 0.32300, 0.27200),
    555: (0.51205, 1.00000, 0.00575),
    600: (1.06220, 0.63100, 0.00080),
    650: (0.28350, 0.10700, 0.00002),
}
D65_XY = (0.31271, 0.32902)          # CIE 15:2004
ILLUMINANT_A_XY = (0.44757, 0.40745)  # CIE 15:2004: black body at 2856 K


def test_cmf_fit_error_vs_cie_table():
    lam = np.array(sorted(CIE_TABLE), dtype=np.float64)
    ref = np.array([CIE_TABLE[k] for k in sorted(CIE_TABLE)])
    err = np.abs(C.cie1931_cmf(lam) - ref)
    # Wyman-Sloan-Shirley multi-lobe fit; measured max 0.0095 (z-bar at 450 nm)
    assert err.max() < 0.011, err
    assert C.cie1931_cmf(lam.astype(np.float32)).dtype == np.float32


def test_planck_wien_peak_and_stefan_boltzmann():
    T = 5000.0
    lam = np.linspace(100.0, 3000.0, 29001)
    B = C.planck(lam, T)
    assert lam[np.argmax(B)] == pytest.approx(2.897771955e6 / T, abs=0.1)   # Wien, nm
    lam2 = np.geomspace(50.0, 1e6, 200001)
    M = math.pi * np.trapezoid(C.planck(lam2, T), lam2)                        # exitance W/m^2
    assert M == pytest.approx(5.670374419e-8 * T ** 4, rel=1e-5)


def test_srgb_matrices_are_inverse_and_map_d65_to_white():
    np.testing.assert_allclose(C.SRGB_FROM_XYZ @ C.XYZ_FROM_SRGB, np.eye(3), atol=1e-4)
    np.testing.assert_array_equal(C.XYZ_FROM_SRGB[1], C.LUMINANCE_WEIGHTS)
    x, y = D65_XY
    xyz = np.array([x / y, 1.0, (1 - x - y) / y])
    np.testing.assert_allclose(C.xyz_to_srgb(xyz), 1.0, atol=1e-3)


def _uv1960(xy):
    x, y = xy
    d = -2 * x + 12 * y + 3
    return np.array([4 * x / d, 6 * y / d])


def _kim_planckian_xy(T):
    """Kim et al. cubic-spline approximation of the Planckian locus (1667-25000 K), ~1e-4 in xy."""
    if T <= 4000:
        x = -0.2661239e9 / T ** 3 - 0.2343589e6 / T ** 2 + 0.8776956e3 / T + 0.179910
    else:
        x = -3.0258469e9 / T ** 3 + 2.1070379e6 / T ** 2 + 0.2226347e3 / T + 0.240390
    if T <= 2222:
        y = -1.1063814 * x ** 3 - 1.34811020 * x ** 2 + 2.18555832 * x - 0.20219683
    elif T <= 4000:
        y = -0.9549476 * x ** 3 - 1.37418593 * x ** 2 + 2.09137015 * x - 0.16748867
    else:
        y = 3.0817580 * x ** 3 - 5.87338670 * x ** 2 + 3.75112997 * x - 0.37001483
    return np.array([x, y])


@pytest.mark.parametrize("T", [2700.0, 4000.0, 6504.0, 10000.0])
def test_blackbody_chromaticity_on_planckian_locus(T):
    xy = C.xyz_to_xy(C.blackbody_xyz(T))
    # measured: <= 1.15e-3 (the CMF fit's error), at 2700 K: (0.4586, 0.4118) vs (0.4593, 0.4107)
    np.testing.assert_allclose(xy, _kim_planckian_xy(T), atol=2.5e-3)


def test_illuminant_a_chromaticity():
    xy = C.xyz_to_xy(C.blackbody_xyz(2856.0))
    np.testing.assert_allclose(xy, ILLUMINANT_A_XY, atol=1.5e-3)    # measured 1.2e-3


def test_6504K_is_close_to_d65():
    xy = C.xyz_to_xy(C.blackbody_xyz(6504.0))
    np.testing.assert_allclose(xy, D65_XY, atol=6e-3)
    # D65 lies Duv ~ +0.0032 off the Planckian locus at its CCT (6504 K): the distance in CIE 1960 uv
    duv = np.linalg.norm(_uv1960(D65_XY) - _uv1960(xy))
    assert duv == pytest.approx(0.0032, abs=6e-4)
    rgb = C.kelvin_to_srgb(6504.0)
    np.testing.assert_allclose(rgb, 1.0, atol=0.05)


def test_kelvin_to_srgb_unit_luminance_and_warm_order():
    T = np.array([1000.0, 2700.0, 4000.0, 6504.0, 20000.0])
    rgb = C.kelvin_to_srgb(T)
    np.testing.assert_allclose(C.luminance(rgb), 1.0, rtol=1e-12)
    assert np.all(rgb >= 0)
    warm = C.kelvin_to_srgb(2700.0)
    assert warm[0] > warm[1] > warm[2] > 0
    assert C.kelvin_to_srgb(20000.0)[2] > C.kelvin_to_srgb(20000.0)[0]   # cool light is bluish


def test_light_temperature_keeps_photometric_value():
    a = pyrt.PointLight((0, 0, 0), candela=250.0, temperature=2700)
    assert a.candela == pytest.approx(250.0)
    np.testing.assert_allclose(a.color, C.kelvin_to_srgb(2700.0))
    with pytest.raises(pyrt.LightError, match="either color or temperature"):
        pyrt.PointLight((0, 0, 0), 1.0, color=(1, 1, 1), temperature=3000)
    with pytest.raises(pyrt.LightError, match="temperature must be"):
        pyrt.SpotLight((0, 0, 0), (0, -1, 0), intensity=1.0, temperature=-5)
    d = pyrt.DirectionalLight((0, -1, 0), lux=1000.0, temperature=5000)
    assert d.lux == pytest.approx(1000.0)
