"""Deterministic quadrature over the sphere of directions for light-power tests."""
import numpy as np


def sphere_integral(fn, axis, breaks=(), n_per_piece=400, n_phi=256):
    """``int_{S^2} fn(w) dw`` for ``fn(w (N, 3)) -> (N, C)``.

    theta is measured from the unit ``axis``; Gauss-Legendre in cos(theta) on each piece between
    the sorted ``breaks`` (cosines where ``fn`` has a kink or a jump), midpoint rule in phi. The
    error is then that of a smooth integrand (~1e-9 relative for the lights tested here).
    """
    axis = np.asarray(axis, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    a = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(axis, a)
    x /= np.linalg.norm(x)
    y = np.cross(axis, x)
    edges = np.unique(np.clip(np.concatenate([[-1.0, 1.0], np.asarray(breaks, dtype=np.float64)]), -1, 1))
    g, gw = np.polynomial.legendre.leggauss(n_per_piece)
    phi = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    total = 0.0
    for lo, hi in zip(edges[:-1], edges[1:]):
        c = lo + (hi - lo) * (g + 1) / 2
        wc = gw * (hi - lo) / 2
        C, P = np.meshgrid(c, phi, indexing="ij")
        s = np.sqrt(np.maximum(0.0, 1 - C * C))
        w = ((s * np.cos(P)).reshape(-1, 1) * x + (s * np.sin(P)).reshape(-1, 1) * y + C.reshape(-1, 1) * axis)
        f = np.asarray(fn(w), dtype=np.float64).reshape(len(c), n_phi, -1)
        total = total + np.einsum("tpc,t->c", f, wc) * (2 * np.pi / n_phi)
    return total
