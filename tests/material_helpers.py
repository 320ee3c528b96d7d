"""Shared by the material tests: a fake surface batch in its own local frame, directions from angles, and a
chi-square test of sampled directions against a pdf."""
import math

import numpy as np
from scipy import stats


class LocalCtx:
    """A surface batch in its own local frame (shading normal +z), constant UV 0.5, no normal map before the
    shading normal (``ns_unmapped`` None): enough for every material's kernels."""

    def __init__(self, n, wo=None):
        self.n_hits = n
        self.dpdu = np.tile([1.0, 0.0, 0.0], (n, 1))
        self.dpdv = np.tile([0.0, 1.0, 0.0], (n, 1))
        self.ns = np.tile([0.0, 0.0, 1.0], (n, 1))
        self.ng = self.ns
        self.front = np.ones(n, dtype=bool)
        self.uv = np.full((n, 2), 0.5)
        self.p = np.zeros((n, 3))
        self.wo = wo if wo is not None else self.ns
        self.ns_unmapped = None
        self.duvdx = self.duvdy = self.dpdx = self.dpdy = None

    def shading_tangents(self, k):
        return self.dpdu, self.dpdv

    def to_local(self, w):
        return np.asarray(w, dtype=np.float64)

    def to_world(self, w):
        return np.asarray(w, dtype=np.float64)


def direction(theta_deg, phi_deg=0.0):
    """The unit vector at polar angle ``theta_deg`` from +z and azimuth ``phi_deg`` (degrees)."""
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def unit(v):
    """``v`` normalised along its last axis."""
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def direction_cos(c, phi):
    """The unit vector of ``cos theta = c`` (clamped to [-1, 1]) and azimuth ``phi`` (radians)."""
    s = np.sqrt(max(0.0, 1.0 - c * c))
    return np.array([s * np.cos(phi), s * np.sin(phi), c])


def chi_square_cells_p(pdf_of, wi, valid, c_edges, p_edges):
    """p-value of a chi-square test of sampled directions ``wi[valid]`` (N, 3) against the density ``pdf_of(w)``
    ((k, 3) unit directions -> (k,)): counts in the (cos theta, phi) cells of ``c_edges`` x ``p_edges`` against the
    pdf integrated over each cell (8 x 8 Gauss points); cells expecting fewer than 5 are pooled with the samples
    outside the cells or not valid and the mass the cells miss. Fails if samples land where the pdf is zero."""
    n = wi.shape[0]
    inside = valid & (wi[:, 2] >= c_edges[0]) & (wi[:, 2] <= c_edges[-1])
    obs, _, _ = np.histogram2d(wi[inside, 2], np.arctan2(wi[inside, 1], wi[inside, 0]), bins=[c_edges, p_edges])
    g, gw = np.polynomial.legendre.leggauss(8)
    exp = np.zeros((c_edges.size - 1, p_edges.size - 1))
    for i in range(exp.shape[0]):
        c = c_edges[i] + (c_edges[i + 1] - c_edges[i]) * (g + 1) / 2
        wc = gw * (c_edges[i + 1] - c_edges[i]) / 2
        for j in range(exp.shape[1]):
            ph = p_edges[j] + (p_edges[j + 1] - p_edges[j]) * (g + 1) / 2
            wp = gw * (p_edges[j + 1] - p_edges[j]) / 2
            cc, pp = np.meshgrid(c, ph, indexing="ij")
            s = np.sqrt(1 - cc * cc)
            w = np.stack([s * np.cos(pp), s * np.sin(pp), cc], -1).reshape(-1, 3)
            exp[i, j] = np.einsum("ab,a,b->", pdf_of(w).reshape(8, 8), wc, wp)
    exp *= n
    obs, exp = obs.ravel(), exp.ravel()
    order = np.argsort(exp)
    small = exp[order] < 5
    pooled_o = obs[order][small].sum() + (n - inside.sum())
    pooled_e = exp[order][small].sum() + max(n - exp.sum(), 0.0)
    o = np.concatenate([obs[order][~small], [pooled_o]])
    e = np.concatenate([exp[order][~small], [pooled_e]])
    keep = e > 0
    assert np.all(o[~keep] == 0), "samples where the pdf is zero"
    return stats.chi2.sf(np.sum((o[keep] - e[keep]) ** 2 / e[keep]), keep.sum() - 1)


def wo_u_cases(seed=3, n=3000):
    """``wo`` (N, 3) and ``u`` (N, 2) for the compiled samplers' twin tests: ``n`` random (upper hemisphere), then
    normal, grazing and just-below-horizon ``wo`` with extreme ``u`` (0, 1e-9, the branch thresholds, the largest
    float below 1), then the grazing ones again with random ``u``."""
    rng = np.random.default_rng(seed)
    wo = unit(rng.normal(size=(n, 3)))
    wo[:, 2] = np.abs(wo[:, 2])
    u = rng.random((n, 2))
    special_wo = [direction_cos(c, phi) for c in (1.0, 0.999999, 1e-3, 1e-6, 0.0, -1e-6) for phi in (0.0, 1.3)]
    special_u = [(a, b) for a in (0.0, 1e-9, 0.25, 0.5, 0.8, 1.0 - 1e-16, np.nextafter(1.0, 0.0))
                 for b in (0.0, 0.3, np.nextafter(1.0, 0.0))]
    wo_s = np.array([w for w in special_wo for _ in special_u])
    u_s = np.array([x for _ in special_wo for x in special_u])
    grazing = np.repeat(np.array(special_wo), 40, axis=0)
    return np.concatenate([wo, wo_s, grazing]), np.concatenate([u, u_s, rng.random((grazing.shape[0], 2))])
