"""Parameter validation shared by the user-facing classes (one place for the common checks)."""
from __future__ import annotations

import math
import numbers

import numpy as np

from pyrt.core.errors import Error


def numbers_array(owner, name, value, error=ValueError):
    """``value`` as a float64 array; ``error`` naming ``owner`` and ``name`` when it is not numbers at all
    (a string, a dict, a ragged list: NumPy's own TypeError / ValueError would not say which parameter)."""
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise error(f"{owner}: {name} must be a number or a list of numbers, got {value!r}") from None


def rgb(owner, name, value, error=ValueError):
    """A non-negative finite RGB triple (a scalar means grey) as float64 (3,); else ``error`` naming it."""
    a = numbers_array(owner, name, value, error)
    if a.ndim == 0:
        a = np.repeat(a, 3)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.any(a < 0):
        raise error(f"{owner}: {name} must be a non-negative finite RGB triple, got {value!r}")
    return a


def _nonfinite(value):
    """True when ``value`` (a real number, a numeric array or a tuple/list of them) holds a NaN or an infinity."""
    if isinstance(value, bool):
        return False
    if isinstance(value, numbers.Real):
        return not math.isfinite(value)
    if isinstance(value, np.ndarray):
        return value.dtype.kind in "fc" and not bool(np.isfinite(value).all())
    if isinstance(value, (tuple, list)):
        return any(_nonfinite(v) for v in value)
    return False


def finite_attributes(owner, obj, error=ValueError):
    """Raise ``error`` naming ``owner`` and the attribute when a public numeric attribute of ``obj`` is not finite.

    The generic half of every family's ``validate()``: the numbers, numeric arrays and tuples of them in
    ``vars(obj)`` (attributes starting with ``_`` are caches and are skipped) must be finite, whatever was
    assigned to them after the object was built. Objects (textures, profiles) are checked by their own class.

    Parameters
    ----------
    owner : str
        The object as messages name it, e.g. ``"PointLight(key)"``.
    obj : object
    error : type
        The family's error class.
    """
    for key, value in vars(obj).items():
        if not key.startswith("_") and _nonfinite(value):
            raise error(f"{owner}: {key} must be finite, got {_short(value)}")


def _short(value):
    """``value`` for a message: arrays of up to 8 numbers as a list, longer ones by their non-finite count."""
    if isinstance(value, np.ndarray):
        if value.size <= 8:
            return repr(value.tolist())
        return f"an array {value.shape} with {int((~np.isfinite(value)).sum())} non-finite values"
    return repr(value)


def integer(owner, name, value, error=ValueError, *, lo=1):
    """``value`` as an int when it is an integer >= ``lo`` (``3.0`` counts, ``True`` and ``2.5`` do not); else ``error``."""
    ok = isinstance(value, (numbers.Integral, float, np.floating)) and not isinstance(value, bool)
    ok = ok and math.isfinite(value) and int(value) == value and int(value) >= lo
    if not ok:
        what = "a positive integer" if lo == 1 else f"an integer >= {lo}"
        raise error(f"{owner}: {name} must be {what}, got {value!r}")
    return int(value)


def finite_number(owner, name, value, error=ValueError, *, lo=None):
    """``value`` as a float when it is a finite real number (>= ``lo`` if given); else ``error``."""
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or (lo is not None and value < lo):
        rng = f" >= {lo}" if lo is not None else ""
        raise error(f"{owner}: {name} must be a finite number{rng}, got {value!r}")
    return float(value)


class FixedAttributeError(Error, AttributeError):
    """A parameter that derived state was computed from was assigned after construction (:class:`Fixed`)."""


class Fixed:
    """A parameter fixed at construction: its constructor sets it once, a later assignment raises
    :class:`FixedAttributeError` naming the object, the attribute and what derives from it (instead of a render
    that silently mixes the new value with state derived from the old one).

    Declared in the class body, ``normal = Fixed("the tangent frame derives from it")``; the value lives in the
    instance's ``__dict__`` under the same name, so ``vars()``, copies and pickles see a plain attribute.
    Assigning the object it already holds is allowed (a no-op).
    """

    def __init__(self, why):
        self.why = why

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        try:
            return obj.__dict__[self.name]
        except KeyError:
            raise AttributeError(f"{type(obj).__name__} has no attribute {self.name!r} yet") from None

    def __set__(self, obj, value):
        d = obj.__dict__
        if self.name in d and d[self.name] is not value:
            label = f"{type(obj).__name__}({d.get('name') or ''})"
            raise FixedAttributeError(f"{label}: {self.name} cannot be changed after construction ({self.why}): "
                                      f"make a new {type(obj).__name__}(...)")
        d[self.name] = value
