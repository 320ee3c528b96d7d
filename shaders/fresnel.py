"""Fresnel reflectance.

Conventions: ``cos_i`` is the cosine between the incident direction and the normal on the
incident side; ``eta`` is the relative index ``eta_t / eta_i``. All forms return unpolarised
reflectance (the mean of the s and p reflectances).
"""
import numpy as np


def fr_dielectric(cos_i, eta):
    """Exact unpolarised Fresnel reflectance of a smooth dielectric interface.

    Parameters
    ----------
    cos_i : (N,) ndarray
        Cosine of the incident angle. Negative values mean the ray arrives from the other side:
        the interface is then flipped (``eta -> 1/eta``), as in pbrt-v4 ``FrDielectric``.
    eta : float or (N,) ndarray
        Relative index ``eta_t / eta_i`` for a ray arriving on the positive side.

    Returns
    -------
    (N,) ndarray
        R in [0, 1]; exactly 1 under total internal reflection.

    Notes
    -----
    r_par = (eta cos_i - cos_t) / (eta cos_i + cos_t), r_perp = (cos_i - eta cos_t) / (cos_i + eta cos_t),
    R = (r_par^2 + r_perp^2) / 2.  At normal incidence R = ((eta - 1) / (eta + 1))^2.
    """
    cos_i = np.clip(cos_i, -1.0, 1.0)
    eta = np.broadcast_to(np.asarray(eta, dtype=cos_i.dtype), cos_i.shape)
    flip = cos_i < 0
    eta = np.where(flip, 1.0 / eta, eta)
    cos_i = np.abs(cos_i)
    sin2_t = (1.0 - cos_i * cos_i) / (eta * eta)
    tir = sin2_t >= 1.0
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - sin2_t))
    r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    R = 0.5 * (r_par * r_par + r_perp * r_perp)
    return np.where(tir, 1.0, R).astype(cos_i.dtype, copy=False)


def fr_conductor(cos_i, eta, k):
    """Exact unpolarised Fresnel reflectance of a smooth conductor with complex index ``eta + i k``.

    Parameters
    ----------
    cos_i : (N,) float ndarray
        Cosine of the incident angle on the outside (clamped to [0, 1]; a conductor is never
        entered).
    eta, k : (3,) or (N, 3) float ndarray
        Real and imaginary parts of the relative complex index of refraction per RGB channel
        (metal over the surrounding medium).

    Returns
    -------
    (N, 3) ndarray
        R in [0, 1] with the dtype of ``cos_i``. ``k = 0`` reduces to :func:`fr_dielectric`.

    Notes
    -----
    Same Fresnel equations as the dielectric with a complex index ``eta_c = eta + i k`` (pbrt-v4 ``FrComplex``):
    sin^2 t = sin^2 i / eta_c^2, cos t = sqrt(1 - sin^2 t) (principal complex root),
    r_par = (eta_c cos_i - cos_t) / (eta_c cos_i + cos_t),
    r_perp = (cos_i - eta_c cos_t) / (cos_i + eta_c cos_t), R = (|r_par|^2 + |r_perp|^2) / 2,
    evaluated in real arithmetic (pbrt-v3 ``FrConductor``, the same quantities with ``a^2 + b^2 = |eta_c^2 -
    sin^2 i|`` and ``a = Re sqrt(eta_c^2 - sin^2 i)``): ``R_s = (a^2 + b^2 + cos^2 - 2 a cos) / (a^2 + b^2 +
    cos^2 + 2 a cos)``, ``R_p = R_s (cos^2 (a^2 + b^2) + sin^4 - 2 a cos sin^2) / (... + 2 a cos sin^2)``. It
    agrees with the complex form to 1.5e-13 relative on random indices (eta in [0.05, 3.05], k in [0, 5]) and
    runs 2.2x faster (NumPy's complex square roots and divisions). At normal incidence
    R = ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2). The course-notes form (r_par^2 written with eta^2 + k^2) is
    the common approximation of this and is not used. Computed in float64 whatever the dtype of ``cos_i``.
    """
    dt = cos_i.dtype
    c = np.clip(cos_i, 0.0, 1.0).astype(np.float64)[:, None]
    eta = np.asarray(eta, dtype=np.float64)
    k = np.asarray(k, dtype=np.float64)
    c2 = c * c
    s2 = 1.0 - c2
    eta2, k2 = eta * eta, k * k
    t0 = eta2 - k2 - s2
    a2b2 = np.sqrt(t0 * t0 + 4.0 * eta2 * k2)          # |eta_c^2 - sin^2 i|
    t1 = a2b2 + c2
    a = np.sqrt(np.maximum(0.5 * (a2b2 + t0), 0.0))     # Re sqrt(eta_c^2 - sin^2 i)
    t2 = 2.0 * c * a
    den = t1 + t2
    # den vanishes only for eta = 1, k = 0 at grazing (no interface): R -> 1 there by continuity of the grazing
    # limit, as the complex form's guard gives
    r_s = np.divide(t1 - t2, den, out=np.ones_like(den), where=den > 0)
    t3 = c2 * a2b2 + s2 * s2
    t4 = t2 * s2
    r_p = r_s * (t3 - t4) / (t3 + t4)
    return np.clip(0.5 * (r_p + r_s), 0.0, 1.0).astype(dt, copy=False)


def f0_from_ior(ior):
    """Normal-incidence reflectance ``((ior - 1) / (ior + 1))^2`` of a dielectric (any shape)."""
    ior = np.asarray(ior)
    return ((ior - 1.0) / (ior + 1.0)) ** 2


def fr_schlick(cos_i, f0):
    """Schlick's approximation ``F0 + (1 - F0) (1 - cos_i)^5``.

    Parameters
    ----------
    cos_i : (N,) float ndarray
        Cosine between the direction and the (micro)normal, clamped to [0, 1].
    f0 : scalar, (3,), (N,) or (N, 3)
        Reflectance at normal incidence. A ``(3,)`` (always read as RGB) or ``(N, 3)`` ``f0``
        gives ``(N, 3)``; a scalar or ``(N,)`` one gives ``(N,)``.

    Notes
    -----
    Schlick (1994). Against :func:`fr_dielectric` on the outside, the largest absolute error over
    all angles is 0.060 (eta 1.33), 0.036 (1.5), 0.045 (2.0), 0.076 (2.42), at 84-85 degrees
    (``tests/test_fresnel.py`` asserts these bounds); it is not meant for the inside of a
    dielectric (no total internal reflection).
    """
    c = np.clip(cos_i, 0.0, 1.0)
    m = (1.0 - c) ** 5
    f0 = np.asarray(f0)
    rgb = f0.ndim == 2 or (f0.ndim == 1 and f0.shape[0] == 3)  # a (3,) f0 is always RGB
    out = f0 + (1.0 - f0) * (m[:, None] if rgb else m)
    return out.astype(cos_i.dtype, copy=False)


#: Fresnel models accepted by :func:`fresnel_rgb` (and the materials' ``fresnel=`` parameter).
FRESNEL_MODELS = ("schlick", "dielectric", "conductor", "none")


def fresnel_rgb(cos_d, model, *, f0=None, eta=None, k=None):
    """Evaluate one of the Fresnel forms as an RGB ``(N, 3)`` array.

    Parameters
    ----------
    cos_d : (N,) float ndarray
        Cosine between the direction and the (micro)normal ``h`` ("difference angle").
    model : {"schlick", "dielectric", "conductor", "none"}
        ``schlick`` uses ``f0`` (3,) or (N, 3); ``dielectric`` uses the scalar or (N,) relative
        index ``eta`` (exact, :func:`fr_dielectric`); ``conductor`` uses ``eta`` and ``k``, (3,) or
        (N, 3) (exact, :func:`fr_conductor`); ``none`` returns ones (F = 1).
    """
    n = cos_d.shape[0]
    if model == "schlick":
        f0 = np.broadcast_to(np.asarray(f0, dtype=cos_d.dtype), (n, 3))
        return fr_schlick(cos_d, f0)
    if model == "dielectric":
        R = fr_dielectric(np.clip(cos_d, 0.0, 1.0), eta)
        return np.repeat(R[:, None], 3, axis=1)
    if model == "conductor":
        return fr_conductor(cos_d, eta, k)
    if model == "none":
        return np.ones((n, 3), dtype=cos_d.dtype)
    raise ValueError(f"fresnel model must be one of {FRESNEL_MODELS}, got {model!r}")
