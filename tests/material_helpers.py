"""Shared by the material tests: a fake surface batch in its own local frame and a direction from angles."""
import math

import numpy as np


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
