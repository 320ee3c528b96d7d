"""Measured complex indices of refraction of metals, reduced to linear-sRGB ``(eta, k)`` triples.

Source
------
Spectral ``eta(lambda)`` and ``k(lambda)`` for gold, silver, copper and aluminium are the tables
pbrt ships as the named spectra ``metal-Au-eta`` / ``metal-Au-k`` etc. (pbrt-v4
``src/pbrt/util/spectrum.cpp``; 56 samples from 298.8 to 885.6 nm; the numbers below were copied
from public ports of those tables, which agree with each other). The pbrt source does not name
the original measurement (commonly attributed to Palik's *Handbook of Optical Constants of
Solids*; not verified here). "Steel" has no spectral table in pbrt: its entry is the single
(eta, k) = (2.485, 3.433) pair of the course notes (``seeds/001``, wavelength not stated), used
for all three channels (grey).

How the RGB triples are made (:func:`derive_rgb_eta_k`, re-run by ``tests/test_fresnel.py``)
------------------------------------------------------------------------------------------
Only reflectance is ever seen, so the reduction matches reflectance, not eta and k themselves:

1. For 90 incidence angles (uniform in theta over [0, 89] degrees) compute the exact spectral
   conductor Fresnel reflectance R(lambda, theta) (:func:`shaders.fresnel.fr_conductor`).
2. Project each R(., theta) to linear sRGB: XYZ with the CIE 1931 2-degree observer (the
   multi-lobe analytic fit of Wyman, Sloan & Shirley 2013, JCGT 2(2)) under an equal-energy
   illuminant, then the XYZ -> linear-sRGB matrix, then divide each channel by that of a perfect
   reflector (R = 1 -> RGB = (1, 1, 1); a von Kries white balance in RGB).
3. Per channel, fit (eta, k) by damped Gauss-Newton to minimise the squared difference between
   ``fr_conductor(theta; eta, k)`` and the projected curve over the 90 angles.

The fitted curves reproduce the projected spectral reflectance to within the residuals printed by
:func:`derive_rgb_eta_k` (max 0.011 over all angles and channels, for gold; <= 0.003 for the
others). Normal-incidence reflectances come out as gold (0.988, 0.790, 0.336), silver
(0.970, 0.960, 0.913), copper (0.934, 0.639, 0.534), aluminium (0.914, 0.921, 0.925).
The table :data:`METALS` holds the result rounded to 4 decimals.
"""
import numpy as np

from . import color
from .fresnel import fr_conductor

#: wavelengths (nm) of the pbrt metal tables
LAMBDA_NM = np.array([
    298.757050, 302.400421, 306.133759, 309.960449, 313.884003, 317.908142, 322.036835,
    326.274139, 330.624481, 335.092377, 339.682678, 344.400482, 349.251221, 354.240509,
    359.374420, 364.659332, 370.102020, 375.709625, 381.489777, 387.450562, 393.600555,
    399.948975, 406.505493, 413.280579, 420.285339, 427.531647, 435.032196, 442.800629,
    450.851562, 459.200653, 467.864838, 476.862213, 486.212463, 495.936707, 506.057861,
    516.600769, 527.592224, 539.061646, 551.040771, 563.564453, 576.670593, 590.400818,
    604.800842, 619.920898, 635.816284, 652.548279, 670.184753, 688.800964, 708.481018,
    729.318665, 751.419250, 774.901123, 799.897949, 826.561157, 855.063293, 885.601257])

#: spectral (eta, k) on :data:`LAMBDA_NM`
SPECTRA = {
    "gold": (np.array([
        1.795000, 1.812000, 1.822625, 1.830000, 1.837125, 1.840000, 1.834250, 1.824000, 1.812000,
        1.798000, 1.782000, 1.766000, 1.752500, 1.740000, 1.727625, 1.716000, 1.705875, 1.696000,
        1.684750, 1.674000, 1.666000, 1.658000, 1.647250, 1.636000, 1.628000, 1.616000, 1.596250,
        1.562000, 1.502125, 1.426000, 1.345875, 1.242000, 1.086750, 0.916000, 0.754500, 0.608000,
        0.491750, 0.402000, 0.345500, 0.306000, 0.267625, 0.236000, 0.212375, 0.194000, 0.177750,
        0.166000, 0.161000, 0.160000, 0.160875, 0.164000, 0.169500, 0.176000, 0.181375, 0.188000,
        0.198125, 0.210000]), np.array([
        1.920375, 1.920000, 1.918875, 1.916000, 1.911375, 1.904000, 1.891375, 1.878000, 1.868250,
        1.860000, 1.851750, 1.846000, 1.845250, 1.848000, 1.852375, 1.862000, 1.883000, 1.906000,
        1.922500, 1.936000, 1.947750, 1.956000, 1.959375, 1.958000, 1.951375, 1.940000, 1.924500,
        1.904000, 1.875875, 1.846000, 1.814625, 1.796000, 1.797375, 1.840000, 1.956500, 2.120000,
        2.326250, 2.540000, 2.730625, 2.880000, 2.940625, 2.970000, 3.015000, 3.060000, 3.070000,
        3.150000, 3.445812, 3.800000, 4.087687, 4.357000, 4.610188, 4.860000, 5.125813, 5.390000,
        5.631250, 5.880000])),
    "silver": (np.array([
        1.519000, 1.496000, 1.432500, 1.323000, 1.142062, 0.932000, 0.719062, 0.526000, 0.388125,
        0.294000, 0.253313, 0.238000, 0.221438, 0.209000, 0.194813, 0.186000, 0.192063, 0.200000,
        0.198063, 0.192000, 0.182000, 0.173000, 0.172625, 0.173000, 0.166688, 0.160000, 0.158500,
        0.157000, 0.151063, 0.144000, 0.137313, 0.132000, 0.130250, 0.130000, 0.129938, 0.130000,
        0.130063, 0.129000, 0.124375, 0.120000, 0.119313, 0.121000, 0.125500, 0.131000, 0.136125,
        0.140000, 0.140063, 0.140000, 0.144313, 0.148000, 0.145875, 0.143000, 0.142563, 0.145000,
        0.151938, 0.163000]), np.array([
        1.080000, 0.882000, 0.761063, 0.647000, 0.550875, 0.504000, 0.554375, 0.663000, 0.818563,
        0.986000, 1.120687, 1.240000, 1.345250, 1.440000, 1.533750, 1.610000, 1.641875, 1.670000,
        1.735000, 1.810000, 1.878750, 1.950000, 2.029375, 2.110000, 2.186250, 2.260000, 2.329375,
        2.400000, 2.478750, 2.560000, 2.640000, 2.720000, 2.798125, 2.880000, 2.973750, 3.070000,
        3.159375, 3.250000, 3.348125, 3.450000, 3.553750, 3.660000, 3.766250, 3.880000, 4.010625,
        4.150000, 4.293125, 4.440000, 4.586250, 4.740000, 4.908125, 5.090000, 5.288750, 5.500000,
        5.720624, 5.950000])),
    "copper": (np.array([
        1.400313, 1.380000, 1.358438, 1.340000, 1.329063, 1.325000, 1.332500, 1.340000, 1.334375,
        1.325000, 1.317812, 1.310000, 1.300313, 1.290000, 1.281563, 1.270000, 1.249062, 1.225000,
        1.200000, 1.180000, 1.174375, 1.175000, 1.177500, 1.180000, 1.178125, 1.175000, 1.172812,
        1.170000, 1.165312, 1.160000, 1.155312, 1.150000, 1.142812, 1.135000, 1.131562, 1.120000,
        1.092437, 1.040000, 0.950375, 0.826000, 0.645875, 0.468000, 0.351250, 0.272000, 0.230813,
        0.214000, 0.209250, 0.213000, 0.216250, 0.223000, 0.236500, 0.250000, 0.254188, 0.260000,
        0.280000, 0.300000]), np.array([
        1.662125, 1.687000, 1.703313, 1.720000, 1.744563, 1.770000, 1.791625, 1.810000, 1.822125,
        1.834000, 1.851750, 1.872000, 1.894250, 1.916000, 1.931688, 1.950000, 1.972438, 2.015000,
        2.121562, 2.210000, 2.177188, 2.130000, 2.160063, 2.210000, 2.249938, 2.289000, 2.326000,
        2.362000, 2.397625, 2.433000, 2.469187, 2.504000, 2.535875, 2.564000, 2.589625, 2.605000,
        2.595562, 2.583000, 2.576500, 2.599000, 2.678062, 2.809000, 3.010750, 3.240000, 3.458187,
        3.670000, 3.863125, 4.050000, 4.239563, 4.430000, 4.619563, 4.817000, 5.034125, 5.260000,
        5.485625, 5.717000])),
    "aluminium": (np.array([
        0.273375, 0.280000, 0.286813, 0.294000, 0.301875, 0.310000, 0.317875, 0.326000, 0.334750,
        0.344000, 0.353813, 0.364000, 0.374375, 0.385000, 0.395750, 0.407000, 0.419125, 0.432000,
        0.445688, 0.460000, 0.474688, 0.490000, 0.506188, 0.523000, 0.540063, 0.558000, 0.577313,
        0.598000, 0.620313, 0.644000, 0.668625, 0.695000, 0.723750, 0.755000, 0.789000, 0.826000,
        0.867000, 0.912000, 0.963000, 1.020000, 1.080000, 1.150000, 1.220000, 1.300000, 1.390000,
        1.490000, 1.600000, 1.740000, 1.910000, 2.140000, 2.410000, 2.630000, 2.800000, 2.740000,
        2.580000, 2.240000]), np.array([
        3.593750, 3.640000, 3.689375, 3.740000, 3.789375, 3.840000, 3.894375, 3.950000, 4.005000,
        4.060000, 4.113750, 4.170000, 4.233750, 4.300000, 4.365000, 4.430000, 4.493750, 4.560000,
        4.633750, 4.710000, 4.784375, 4.860000, 4.938125, 5.020000, 5.108750, 5.200000, 5.290000,
        5.380000, 5.480000, 5.580000, 5.690000, 5.800000, 5.915000, 6.030000, 6.150000, 6.280000,
        6.420000, 6.550000, 6.700000, 6.850000, 7.000000, 7.150000, 7.310000, 7.480000, 7.650000,
        7.820000, 8.010000, 8.210000, 8.390000, 8.570000, 8.620000, 8.600000, 8.450000, 8.310000,
        8.210000, 8.210000])),
}

#: course-notes single-wavelength value for steel (grey), see the module docstring
STEEL_ETA_K = (2.485, 3.433)

def reflectance_to_rgb(lam, R):
    """Project spectral reflectances to white-balanced linear sRGB.

    Parameters
    ----------
    lam : (M,) ndarray
        Wavelengths (nm), increasing.
    R : (..., M) ndarray
        Reflectance per wavelength.

    Returns
    -------
    (..., 3) ndarray
        Linear sRGB with a perfect reflector mapped to (1, 1, 1) (equal-energy illuminant,
        trapezoidal integration on the given samples; :func:`shaders.color.spectrum_to_xyz`).
    """
    # one colorimetry for the whole project: shaders.color's CIE 1931 fit, trapezoid integral and matrix
    rgb = color.xyz_to_srgb(color.spectrum_to_xyz(lam, R))
    white = color.xyz_to_srgb(color.spectrum_to_xyz(lam, np.ones(np.shape(lam))))
    return rgb / white


def _fit_channel(cos_t, target, eta0, k0, iters=60):
    """Damped Gauss-Newton fit of (eta, k) so that fr_conductor(cos_t) ~ target."""
    p = np.array([eta0, k0], dtype=np.float64)

    def model(q):
        return fr_conductor(cos_t, np.full(3, q[0]), np.full(3, q[1]))[:, 0]

    lam_damp = 1e-3
    for _ in range(iters):
        r = model(p) - target
        jac = np.empty((cos_t.shape[0], 2))
        for j in range(2):
            dp = np.zeros(2)
            dp[j] = 1e-6 * max(1.0, abs(p[j]))
            jac[:, j] = (model(p + dp) - model(p - dp)) / (2 * dp[j])
        a = jac.T @ jac + lam_damp * np.eye(2)
        step = np.linalg.solve(a, -jac.T @ r)
        q = np.maximum(p + step, 1e-4)
        if np.sum((model(q) - target) ** 2) < np.sum(r * r):
            p, lam_damp = q, lam_damp * 0.3
        else:
            lam_damp *= 10.0
    return p, float(np.max(np.abs(model(p) - target)))


def derive_rgb_eta_k(name):
    """Reduce the spectral table of ``name`` to RGB ``(eta (3,), k (3,), max_residual)``.

    See the module docstring for the method.
    """
    eta_s, k_s = SPECTRA[name]
    theta = np.radians(np.linspace(0.0, 89.0, 90))
    cos_t = np.cos(theta)
    # spectral reflectance (90, M): evaluate fr_conductor with the wavelength as the channel axis
    R = np.stack([fr_conductor(cos_t, np.full(3, e), np.full(3, kk))[:, 0]
                  for e, kk in zip(eta_s, k_s)], axis=1)
    target = reflectance_to_rgb(LAMBDA_NM, R)  # (90, 3)
    eta, k, worst = np.zeros(3), np.zeros(3), 0.0
    for c, lam_c in enumerate((610.0, 550.0, 465.0)):
        e0, k0 = np.interp(lam_c, LAMBDA_NM, eta_s), np.interp(lam_c, LAMBDA_NM, k_s)
        (eta[c], k[c]), res = _fit_channel(cos_t, target[:, c], e0, k0)
        worst = max(worst, res)
    return eta, k, worst


#: name -> (eta (3,), k (3,)) in linear sRGB, from :func:`derive_rgb_eta_k` rounded to 4 decimals
METALS = {
    "gold": (np.array([0.2047, 0.3952, 1.5968]), np.array([8.2402, 2.3614, 1.6977])),
    "silver": (np.array([0.1285, 0.1246, 0.1527]), np.array([3.9993, 3.3645, 2.3895])),
    "copper": (np.array([0.2002, 0.9709, 1.2196]), np.array([3.2575, 2.6221, 2.3517])),
    "aluminium": (np.array([1.3776, 0.9346, 0.5807]), np.array([7.6335, 6.6212, 5.3171])),
    "steel": (np.full(3, STEEL_ETA_K[0]), np.full(3, STEEL_ETA_K[1])),
}
#: accepted spellings
METALS["aluminum"] = METALS["aluminium"]


def metal_eta_k(name):
    """``(eta (3,), k (3,))`` copies for a metal of :data:`METALS`; ``KeyError`` lists the names."""
    key = str(name).lower()
    if key not in METALS:
        raise KeyError(f"unknown metal {name!r}; known: {sorted(METALS)}")
    eta, k = METALS[key]
    return eta.copy(), k.copy()
