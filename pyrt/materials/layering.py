"""What layered materials share: a layer over a base material (:class:`pyrt.materials.Clearcoat`,
:class:`pyrt.materials.Sheen`) keeps the base's integrator-facing attributes, weights its delta lobes, mixes two
sampling strategies by one random number and finishes a sample by evaluating the mixture."""
from __future__ import annotations

import numpy as np

from pyrt.core.checks import Fixed
from pyrt.materials.base import DeltaLobe, Material, MaterialError
from pyrt.materials.library import MetallicRoughness


class Layer(Material):
    """A layer over a material (:attr:`base`, set by :func:`adopt_base`): what passes the layer is the base's."""

    #: the material under the layer; fixed: the attributes the integrators read are copied from it
    base = Fixed("the layer's dielectric, delta, emission and normal-map attributes were copied from it")

    def rough_transmission(self, ctx):
        """The base's (a coat or a sheen reflects; it does not stop what the base transmits)."""
        return self.base.rough_transmission(ctx)

    @property
    def tint(self):
        """The base's, as it is now (a coat or a sheen does not filter what the base transmits)."""
        return self.base.tint


def split_u(u, p):
    """``(choose, uu)``: lanes with ``u0 < p`` choose the first strategy; ``uu`` is ``u`` with ``u0`` rescaled to
    [0, 1) inside each branch (as :class:`pyrt.materials.library.CookTorrance` does)."""
    choose = u[:, 0] < p
    u0 = np.where(choose, u[:, 0] / np.where(p > 0, p, 1.0), (u[:, 0] - p) / np.where(p < 1, 1.0 - p, 1.0))
    return choose, np.stack([np.clip(u0, 0.0, 1.0 - 1e-12), u[:, 1]], axis=1)


def adopt_base(layer, base):
    """``layer.base = base`` (default :class:`MetallicRoughness` ()), checked, and the attributes the integrators
    read copied from it (declared on :class:`Material`; a coat or a sheen on top changes none of them)."""
    base = MetallicRoughness() if base is None else base
    if not isinstance(base, Material):
        raise MaterialError(f"{layer.label}: base must be a pyrt Material, got {type(base).__name__}")
    layer.base = base
    for attr in ("has_delta", "is_dielectric", "ior", "priority", "absorption", "emits", "normal_map",
                 "transmits", "thin_walled"):
        setattr(layer, attr, getattr(base, attr))
    return base


def weighted_delta_lobes(base, wo, ctx, eta, weight):
    """``base``'s delta lobes at local ``wo``, each weight times ``weight(wo, ctx)`` (N,), computed only when there are
    lobes: what a layer on top (a clear coat, a sheen) leaves of the base's mirror and glass lobes."""
    lobes = base.delta_lobes(wo, ctx, **({} if eta is None else {"eta": eta}))
    if not lobes:
        return lobes
    keep = weight(wo, ctx)[:, None]
    return [DeltaLobe(lb.wi, lb.weight * keep, lb.kind, lb.eta) for lb in lobes]


def finish_sample(mat, wo, wi, valid, ctx):
    """``(wi, f_cos / pdf, pdf)`` for sampled directions, zero where ``valid`` is False or the pdf is 0."""
    wi = np.where(valid[:, None], wi, 0.0)
    pdf = np.where(valid, mat.pdf(wo, wi, ctx), 0.0)
    f = mat.f_cos(wo, wi, ctx)
    ok = pdf > 0
    weight = np.where(ok[:, None], f / np.where(ok, pdf, 1.0)[:, None], 0.0)
    return wi, weight, np.where(ok, pdf, 0.0)
