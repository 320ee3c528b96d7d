"""Microfacet distributions, masking-shadowing terms and their sampling.

All functions take cosines (or unit directions) in the local shading frame, z = macro normal,
as ``(N,)`` / ``(N, 3)`` arrays; ``alpha`` is a scalar or ``(N,)``. Outputs keep the float dtype of
the direction/cosine input. Nothing here draws random numbers: samplers take ``u`` (N, 2).

Roughness parameterisation (stated once for the whole library)
-------------------------------------------------------------
``alpha`` is the microfacet width: the RMS slope of the Beckmann distribution, the GGX
(Trowbridge-Reitz) width, Ward's sigma. Materials and scene files take the *perceptual*
``roughness`` in [0, 1] and map it with ``alpha = roughness**2`` (:func:`roughness_to_alpha`;
Burley 2012, UE4, glTF 2.0), or take ``alpha`` directly. The Blinn distribution's exponent is tied
to alpha by ``n = 2 / alpha^2 - 2`` (Walter et al. 2007, sec. 5.2), so the three distributions
have comparable highlights for the same alpha. ``alpha`` is clamped below at :data:`ALPHA_MIN`.

Terms provided
--------------
- D: :func:`ggx_d`, :func:`beckmann_d`, :func:`blinn_d` — each normalised so that
  ``integral D(h) (n.h) dw_h = 1`` over the hemisphere.
- Smith Lambda: :func:`ggx_lambda` (closed form), :func:`beckmann_lambda` (exact, with erfc);
  G1 = 1 / (1 + Lambda); G2 separable = G1(wo) G1(wi); G2 height-correlated =
  1 / (1 + Lambda(wo) + Lambda(wi)) (Heitz 2014, "Understanding the masking-shadowing function").
- :func:`vgroove_g`: Cook & Torrance (1982) V-groove G = min(1, 2 (n.h)(n.o)/(o.h), 2 (n.h)(n.i)/(o.h)).
- :func:`schlick_g1` with ``k`` from :func:`schlick_k` (k = alpha / 2, Karis 2013, which matches
  Smith-GGX) or :func:`schlick_k_ue4_direct` (k = (roughness + 1)^2 / 8, UE4's "direct lighting"
  remap of roughness to (roughness + 1) / 2 before squaring, meant to reduce hotness of
  rough surfaces under analytic lights; it is *not* a better fit to Smith).
- Anisotropic GGX (``alpha_x`` along the frame's x axis, ``alpha_y`` along y; directions given in that frame):
  :func:`ggx_d_aniso`, :func:`ggx_lambda_aniso` (the isotropic Lambda of the projected width, Heitz 2014 sec. 5.3),
  :func:`ggx_g2_aniso`; :func:`sample_ggx_vndf` and :func:`ggx_vndf_pdf` take ``alpha_y`` too.
  :func:`gltf_anisotropic_alpha` is ``KHR_materials_anisotropy``'s ``alpha_t = mix(alpha, 1, strength^2)``.
- Sampling: :func:`sample_ggx_vndf` (visible normals, Heitz 2018 JCGT 7(4), isotropic or anisotropic) with
  :func:`ggx_vndf_pdf`; :func:`sample_ggx_ndf` / :func:`sample_beckmann_ndf` (density D(h) (n.h)),
  and :func:`reflect_pdf` to turn a half-vector density into a density of ``wi``
  (``wi = shaders.vec.reflect(wo, h)``).
"""
import numpy as np

#: smallest alpha used by the kernels (D peaks at 1/(pi alpha^2) ~ 3e7: finite in float32)
ALPHA_MIN = 1e-4

#: distributions and geometry terms the microfacet BRDFs accept (see :func:`g2`)
DISTRIBUTIONS = ("ggx", "beckmann", "blinn")
GEOMETRY_TERMS = ("smith_correlated", "smith_separable", "vgroove", "schlick", "schlick_ue4", "none")

_SQRT_PI = np.sqrt(np.pi)


def roughness_to_alpha(roughness):
    """Perceptual roughness in [0, 1] -> microfacet alpha = roughness^2 (the library's one mapping)."""
    return np.asarray(roughness) ** 2


def _alpha(alpha, dtype):
    return np.maximum(np.asarray(alpha, dtype=dtype), ALPHA_MIN)


def blinn_exponent_from_alpha(alpha):
    """Blinn exponent equivalent to a Beckmann width: ``n = 2 / alpha^2 - 2`` (Walter et al. 2007)."""
    a = np.maximum(np.asarray(alpha), ALPHA_MIN)
    return np.maximum(2.0 / (a * a) - 2.0, 0.0)


def alpha_from_blinn_exponent(exponent):
    """Inverse of :func:`blinn_exponent_from_alpha`: ``alpha = sqrt(2 / (n + 2))``."""
    return np.sqrt(2.0 / (np.asarray(exponent) + 2.0))


# --------------------------------------------------------------------------- distributions D


def ggx_d(cos_h, alpha):
    """GGX / Trowbridge-Reitz NDF ``alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2)``; 0 for n.h <= 0.

    Parameters
    ----------
    cos_h : (N,) float ndarray
        n . h for unit half vectors.
    alpha : float or (N,) ndarray
        Width (clamped to :data:`ALPHA_MIN`).
    """
    a2 = _alpha(alpha, cos_h.dtype) ** 2
    c2 = cos_h * cos_h
    # sin^2 + alpha^2 cos^2 (= c2 (a2 - 1) + 1, written so that float32 keeps a2 at c = 1)
    den = (1.0 - cos_h) * (1.0 + cos_h) + a2 * c2
    d = a2 / (np.pi * den * den)
    return np.where(cos_h > 0, d, 0.0).astype(cos_h.dtype, copy=False)


def ggx_d_aniso(h, alpha_x, alpha_y):
    """Anisotropic GGX NDF ``1 / (pi ax ay ((h.x/ax)^2 + (h.y/ay)^2 + (h.z)^2)^2)``; 0 for h.z <= 0.

    Walter et al. 2007 / Heitz 2014 (eq. 85); the ``D`` of ``KHR_materials_anisotropy`` with ``x = t`` (``alpha_t``)
    and ``y = b`` (``alpha_b``). Normalised (``integral D(h) (n.h) dw_h = 1``, tested); ``ax = ay = alpha`` is
    :func:`ggx_d` (to rounding).

    Parameters
    ----------
    h : (N, 3) float ndarray
        Unit half vectors in the anisotropy frame (x along ``alpha_x``, z the macro normal).
    alpha_x, alpha_y : float or (N,)
        Widths along x and y (each clamped to :data:`ALPHA_MIN`).
    """
    ax = _alpha(alpha_x, h.dtype)
    ay = _alpha(alpha_y, h.dtype)
    cz = h[:, 2]
    den = (h[:, 0] / ax) ** 2 + (h[:, 1] / ay) ** 2 + cz * cz
    d = np.divide(1.0, np.pi * ax * ay * den * den, out=np.zeros_like(cz), where=den > 0)
    return np.where(cz > 0, d, 0.0).astype(h.dtype, copy=False)


def beckmann_d(cos_h, alpha):
    """Beckmann NDF ``exp(-tan^2 theta_h / alpha^2) / (pi alpha^2 cos^4 theta_h)``; 0 for n.h <= 0."""
    a2 = _alpha(alpha, cos_h.dtype) ** 2
    c = np.where(cos_h > 0, cos_h, 1.0)
    c2 = c * c
    tan2 = (1.0 - c2) / c2
    d = np.exp(-tan2 / a2) / (np.pi * a2 * c2 * c2)
    return np.where(cos_h > 0, d, 0.0).astype(cos_h.dtype, copy=False)


def blinn_d(cos_h, exponent):
    """Normalised Blinn NDF ``(n + 2) / (2 pi) (n.h)^n``; 0 for n.h <= 0."""
    e = np.asarray(exponent, dtype=cos_h.dtype)
    d = (e + 2.0) / (2.0 * np.pi) * np.power(np.maximum(cos_h, 0.0), e)
    return np.where(cos_h > 0, d, 0.0).astype(cos_h.dtype, copy=False)


def ndf(cos_h, alpha, distribution):
    """Dispatch ``distribution`` in :data:`DISTRIBUTIONS`; Blinn uses the alpha-equivalent exponent."""
    if distribution == "ggx":
        return ggx_d(cos_h, alpha)
    if distribution == "beckmann":
        return beckmann_d(cos_h, alpha)
    if distribution == "blinn":
        return blinn_d(cos_h, blinn_exponent_from_alpha(alpha))
    raise ValueError(f"distribution must be one of {DISTRIBUTIONS}, got {distribution!r}")


# --------------------------------------------------------------------------- Smith terms


def erfc(x):
    """Complementary error function, fractional error < 1.2e-7 everywhere (no scipy in shaders).

    Chebyshev-fitted form of Press et al., Numerical Recipes (2nd ed., sec. 6.2, ``erfcc``).
    """
    z = np.abs(x)
    t = 1.0 / (1.0 + 0.5 * z)
    poly = -1.26551223 + t * (1.00002368 + t * (0.37409196 + t * (0.09678418 + t * (
        -0.18628806 + t * (0.27886807 + t * (-1.13520398 + t * (1.48851587 + t * (
            -0.82215223 + t * 0.17087277))))))))
    ans = t * np.exp(-z * z + poly)
    return np.where(x >= 0, ans, 2.0 - ans)


def _tan_inv(cos_v):
    """``cot theta = cos / sin`` with 0 below the horizon (caller masks those lanes)."""
    c = np.clip(cos_v, 0.0, 1.0)
    s = np.sqrt(np.maximum(0.0, 1.0 - c * c))
    return np.divide(c, s, out=np.full_like(c, np.inf), where=s > 0)


def ggx_lambda(cos_v, alpha):
    """Smith Lambda for GGX: ``(sqrt(1 + alpha^2 tan^2 theta) - 1) / 2``; +inf at/below the horizon."""
    a2 = _alpha(alpha, cos_v.dtype) ** 2
    c = np.clip(cos_v, 0.0, 1.0)
    root = np.sqrt(a2 + (1.0 - a2) * c * c)  # = cos * sqrt(1 + a^2 tan^2)
    lam = np.divide(root - c, 2.0 * c, out=np.full_like(c, np.inf), where=c > 0)
    return lam.astype(cos_v.dtype, copy=False)


def projected_alpha(w, alpha_x, alpha_y):
    """The width an anisotropic distribution has in the plane of ``w`` and the normal:
    ``sqrt((ax^2 w.x^2 + ay^2 w.y^2) / (w.x^2 + w.y^2))`` (Heitz 2014, sec. 5.3); ``alpha_x`` at normal incidence
    (where Lambda is 0 whatever the width). (N,) in the dtype of ``w``."""
    ax = _alpha(alpha_x, w.dtype)
    ay = _alpha(alpha_y, w.dtype)
    s2 = w[:, 0] ** 2 + w[:, 1] ** 2
    a2 = np.divide(ax * ax * w[:, 0] ** 2 + ay * ay * w[:, 1] ** 2, s2, out=np.broadcast_to(ax * ax, s2.shape).copy(),
                   where=s2 > 0)
    return np.sqrt(a2).astype(w.dtype, copy=False)


def ggx_lambda_aniso(w, alpha_x, alpha_y):
    """Smith Lambda of anisotropic GGX: :func:`ggx_lambda` of the projected width (:func:`projected_alpha`), i.e.
    ``(sqrt(1 + (ax^2 w.x^2 + ay^2 w.y^2) / w.z^2) - 1) / 2`` (Heitz 2014, eq. 86); +inf at/below the horizon.

    ``w`` (N, 3) unit directions in the anisotropy frame.
    """
    return ggx_lambda(w[:, 2], projected_alpha(w, alpha_x, alpha_y))


def ggx_g2_aniso(wo, wi, alpha_x, alpha_y, geometry="smith_correlated"):
    """Smith masking-shadowing of anisotropic GGX for ``wo``, ``wi`` (N, 3) in the anisotropy frame:
    ``1 / (1 + Lambda(wo) + Lambda(wi))`` (``"smith_correlated"``, height-correlated: ``KHR_materials_anisotropy``'s
    ``V = G2 / (4 n.l n.v)``) or ``G1(wo) G1(wi)`` (``"smith_separable"``); 0 where either is below the horizon."""
    lo = ggx_lambda_aniso(wo, alpha_x, alpha_y)
    li = ggx_lambda_aniso(wi, alpha_x, alpha_y)
    if geometry == "smith_correlated":
        g = 1.0 / (1.0 + lo + li)
    elif geometry == "smith_separable":
        g = 1.0 / ((1.0 + lo) * (1.0 + li))
    else:
        raise ValueError(f"anisotropic GGX takes geometry 'smith_correlated' or 'smith_separable', got {geometry!r}")
    return g.astype(wo.dtype, copy=False)


def gltf_anisotropic_alpha(alpha, strength):
    """``KHR_materials_anisotropy``'s width along the anisotropy direction: ``alpha_t = mix(alpha, 1, strength^2)``
    (the width across it, ``alpha_b``, stays ``alpha``); ``strength`` 0 gives ``alpha`` exactly."""
    s2 = np.asarray(strength) ** 2
    return alpha + (1.0 - alpha) * s2


def beckmann_lambda(cos_v, alpha):
    """Exact Smith Lambda for Beckmann: ``(exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2``, a = cot / alpha.

    +inf at/below the horizon, 0 at normal incidence.
    """
    al = _alpha(alpha, cos_v.dtype)
    a = _tan_inv(cos_v) / al
    fin = np.isfinite(a) & (a > 0)
    a_s = np.where(fin, a, 1.0)
    lam = 0.5 * (np.exp(-a_s * a_s) / (a_s * _SQRT_PI) - erfc(a_s))
    lam = np.where(fin, np.maximum(lam, 0.0), np.where(a > 0, 0.0, np.inf))
    return lam.astype(cos_v.dtype, copy=False)


def smith_lambda(cos_v, alpha, distribution):
    """Lambda of ``distribution``; Blinn uses the Beckmann Lambda of the same alpha (Walter 2007)."""
    if distribution == "ggx":
        return ggx_lambda(cos_v, alpha)
    if distribution in ("beckmann", "blinn"):
        return beckmann_lambda(cos_v, alpha)
    raise ValueError(f"distribution must be one of {DISTRIBUTIONS}, got {distribution!r}")


def smith_g1(cos_v, alpha, distribution="ggx"):
    """Smith masking ``G1 = 1 / (1 + Lambda)`` in [0, 1]; 0 at or below the horizon."""
    lam = smith_lambda(cos_v, alpha, distribution)
    return (1.0 / (1.0 + lam)).astype(cos_v.dtype, copy=False)


def smith_g2_separable(cos_o, cos_i, alpha, distribution="ggx"):
    """Separable Smith masking-shadowing ``G1(wo) G1(wi)``."""
    return smith_g1(cos_o, alpha, distribution) * smith_g1(cos_i, alpha, distribution)


def smith_g2_correlated(cos_o, cos_i, alpha, distribution="ggx"):
    """Height-correlated Smith ``1 / (1 + Lambda(wo) + Lambda(wi))`` (Heitz 2014, eq. 99)."""
    lo = smith_lambda(cos_o, alpha, distribution)
    li = smith_lambda(cos_i, alpha, distribution)
    return (1.0 / (1.0 + lo + li)).astype(cos_o.dtype, copy=False)


def vgroove_g(cos_o, cos_i, cos_h, cos_oh):
    """Cook-Torrance V-groove ``min(1, 2 (n.h)(n.o)/(o.h), 2 (n.h)(n.i)/(o.h))``, 0 where o.h <= 0."""
    ok = cos_oh > 0
    inv = np.divide(2.0 * cos_h, cos_oh, out=np.zeros_like(cos_oh), where=ok)
    g = np.minimum(1.0, np.minimum(inv * cos_o, inv * cos_i))
    return np.where(ok, np.clip(g, 0.0, 1.0), 0.0).astype(cos_o.dtype, copy=False)


def schlick_k(alpha):
    """Schlick-GGX ``k = alpha / 2`` (Karis 2013), which makes :func:`schlick_g1` follow Smith-GGX."""
    return np.asarray(alpha) / 2.0


def schlick_k_ue4_direct(roughness):
    """UE4 analytic-light variant ``k = (roughness + 1)^2 / 8`` (Karis 2013), roughness = sqrt(alpha)."""
    return (np.asarray(roughness) + 1.0) ** 2 / 8.0


def schlick_g1(cos_v, k):
    """Schlick's G1 ``cos / (cos (1 - k) + k)``, 0 at or below the horizon."""
    c = np.clip(cos_v, 0.0, 1.0)
    k = np.asarray(k, dtype=cos_v.dtype)
    den = c * (1.0 - k) + k
    g = np.divide(c, den, out=np.zeros_like(c), where=den > 0)
    return g.astype(cos_v.dtype, copy=False)


def g2(cos_o, cos_i, cos_h, cos_oh, alpha, distribution, geometry):
    """Masking-shadowing term chosen by name (:data:`GEOMETRY_TERMS`).

    ``smith_correlated`` / ``smith_separable`` use the exact Lambda of ``distribution``;
    ``vgroove`` the Cook-Torrance form; ``schlick`` Schlick-GGX with k = alpha/2 and
    ``schlick_ue4`` with k = (sqrt(alpha) + 1)^2 / 8, both as the separable product
    G1(wo) G1(wi); ``none`` is G = 1 (the bare ``D F / (4 cos cos)``).
    """
    if geometry == "smith_correlated":
        return smith_g2_correlated(cos_o, cos_i, alpha, distribution)
    if geometry == "smith_separable":
        return smith_g2_separable(cos_o, cos_i, alpha, distribution)
    if geometry == "vgroove":
        return vgroove_g(cos_o, cos_i, cos_h, cos_oh)
    if geometry == "schlick":
        k = schlick_k(_alpha(alpha, cos_o.dtype))
        return schlick_g1(cos_o, k) * schlick_g1(cos_i, k)
    if geometry == "schlick_ue4":
        k = schlick_k_ue4_direct(np.sqrt(_alpha(alpha, cos_o.dtype)))
        return schlick_g1(cos_o, k) * schlick_g1(cos_i, k)
    if geometry == "none":
        return np.where((cos_o > 0) & (cos_i > 0), 1.0, 0.0).astype(cos_o.dtype, copy=False)
    raise ValueError(f"geometry must be one of {GEOMETRY_TERMS}, got {geometry!r}")


# --------------------------------------------------------------------------- sampling


def _spherical(cos_t, phi):
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t * cos_t))
    return np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=1)


def sample_ggx_ndf(u, alpha):
    """Half vectors with density ``D_ggx(h) (n.h)``: ``tan^2 theta = alpha^2 u0 / (1 - u0)``.

    Returns ``(N, 3)`` unit half vectors (upper hemisphere), dtype of ``u``.
    """
    a2 = _alpha(alpha, u.dtype) ** 2
    u0 = u[:, 0]
    # cos^2 = 1 / (1 + tan^2) = (1 - u0) / (1 - u0 + a2 u0): no division by zero for u0 in [0, 1)
    cos2 = (1.0 - u0) / (1.0 - u0 + a2 * u0)
    return _spherical(np.sqrt(cos2), 2.0 * np.pi * u[:, 1]).astype(u.dtype, copy=False)


def sample_beckmann_ndf(u, alpha):
    """Half vectors with density ``D_beckmann(h) (n.h)``: ``tan^2 theta = -alpha^2 log(1 - u0)``."""
    a2 = _alpha(alpha, u.dtype) ** 2
    tan2 = -a2 * np.log1p(-np.minimum(u[:, 0], 1.0 - 1e-16))
    cos_t = 1.0 / np.sqrt(1.0 + tan2)
    return _spherical(cos_t, 2.0 * np.pi * u[:, 1]).astype(u.dtype, copy=False)


def ndf_pdf(h, alpha, distribution):
    """Density ``D(h) (n.h)`` (solid angle of h) of the ``sample_*_ndf`` samplers."""
    return ndf(h[:, 2], alpha, distribution) * np.maximum(h[:, 2], 0.0)


def sample_ggx_vndf(wo, u, alpha, alpha_y=None):
    """Sample GGX visible normals from ``wo`` (Heitz 2018, "Sampling the GGX Distribution of Visible
    Normals", JCGT 7(4), listing 1), isotropic or anisotropic.

    Parameters
    ----------
    wo : (N, 3) float ndarray
        Unit direction toward the viewer, local frame, ``wo.z > 0`` (other lanes give garbage-free
        but meaningless upper-hemisphere normals; their pdf is 0). With ``alpha_y``, the frame's x axis is
        the direction of width ``alpha``.
    u : (N, 2) float ndarray in [0, 1)^2
    alpha : float or (N,)
        The width (isotropic), or the width along x when ``alpha_y`` is given.
    alpha_y : float or (N,), optional
        The width along y (default: ``alpha``, the isotropic sampler, bit for bit).

    Returns
    -------
    (N, 3) ndarray
        Unit microfacet normals h with density :func:`ggx_vndf_pdf` (of the same widths).
    """
    al = _alpha(alpha, wo.dtype)
    al = np.broadcast_to(al, wo.shape[:1])
    ay = al if alpha_y is None else np.broadcast_to(_alpha(alpha_y, wo.dtype), wo.shape[:1])
    wz = np.maximum(wo[:, 2], 0.0)
    vh = np.stack([al * wo[:, 0], ay * wo[:, 1], wz], axis=1)
    vh_len = np.sqrt(np.einsum("ij,ij->i", vh, vh))
    vh = vh / np.where(vh_len > 0, vh_len, 1.0)[:, None]
    vh[vh_len == 0] = (0.0, 0.0, 1.0)
    lensq = vh[:, 0] ** 2 + vh[:, 1] ** 2
    inv = np.divide(1.0, np.sqrt(lensq), out=np.zeros_like(lensq), where=lensq > 0)
    t1 = np.stack([-vh[:, 1] * inv, vh[:, 0] * inv, np.zeros_like(lensq)], axis=1)
    t1[lensq == 0] = (1.0, 0.0, 0.0)
    t2 = np.cross(vh, t1)
    r = np.sqrt(u[:, 0])
    phi = 2.0 * np.pi * u[:, 1]
    p1 = r * np.cos(phi)
    p2 = r * np.sin(phi)
    s = 0.5 * (1.0 + vh[:, 2])
    p2 = (1.0 - s) * np.sqrt(np.maximum(0.0, 1.0 - p1 * p1)) + s * p2
    p3 = np.sqrt(np.maximum(0.0, 1.0 - p1 * p1 - p2 * p2))
    nh = p1[:, None] * t1 + p2[:, None] * t2 + p3[:, None] * vh
    ne = np.stack([al * nh[:, 0], ay * nh[:, 1], np.maximum(nh[:, 2], 0.0)], axis=1)
    n_len = np.sqrt(np.einsum("ij,ij->i", ne, ne))
    ne = ne / np.where(n_len > 0, n_len, 1.0)[:, None]
    ne[n_len == 0] = (0.0, 0.0, 1.0)
    return ne.astype(wo.dtype, copy=False)


def ggx_vndf_pdf(wo, h, alpha, alpha_y=None):
    """Density of :func:`sample_ggx_vndf`: ``G1(wo) max(0, wo.h) D(h) / wo.z`` (0 where wo.z <= 0); with
    ``alpha_y`` the anisotropic ``D`` and ``G1`` (:func:`ggx_d_aniso`, :func:`ggx_lambda_aniso`)."""
    co = wo[:, 2]
    coh = np.maximum(np.einsum("ij,ij->i", wo, h), 0.0)
    if alpha_y is None:
        g1 = 1.0 / (1.0 + ggx_lambda(co, alpha))
        d = ggx_d(h[:, 2], alpha)
    else:
        g1 = 1.0 / (1.0 + ggx_lambda_aniso(wo, alpha, alpha_y))
        d = ggx_d_aniso(h, alpha, alpha_y)
    val = np.divide(g1 * coh * d, co, out=np.zeros_like(co), where=co > 0)
    return val.astype(wo.dtype, copy=False)


def reflect_pdf(pdf_h, wo, h):
    """Density of ``wi = reflect(wo, h)`` from a half-vector density: ``pdf_h / (4 |wo.h|)``."""
    coh = np.abs(np.einsum("ij,ij->i", wo, h))
    return np.divide(pdf_h, 4.0 * coh, out=np.zeros_like(pdf_h), where=coh > 0)

