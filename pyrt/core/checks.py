"""Parameter validation shared by the user-facing classes (one place for the common checks)."""
from __future__ import annotations

import numpy as np


def rgb(owner, name, value, error=ValueError):
    """A non-negative finite RGB triple (a scalar means grey) as float64 (3,); else ``error`` naming it."""
    a = np.asarray(value, dtype=np.float64)
    if a.ndim == 0:
        a = np.repeat(a, 3)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.any(a < 0):
        raise error(f"{owner}: {name} must be a non-negative finite RGB triple, got {value!r}")
    return a
