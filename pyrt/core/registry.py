"""One registry mechanism for every plugin family (materials, lights, environments, textures).

A family creates one :class:`Registry` next to its base class and registers each type with a decorator::

    MATERIALS = Registry("material", Material)

    @MATERIALS.register("lambert")
    class Lambert(Material): ...

The scene-file loader (:func:`pyrt.load_dict`) reads ``{"type": "lambert", ...}`` through the registry,
and the contract tests (``tests/test_contracts.py``) are parametrised over it, so a new type needs no
hand-kept list anywhere.
"""
from __future__ import annotations

from pyrt.core.errors import Error


class RegistryError(Error, ValueError):
    """A type is registered twice, is not of the family's base class, or is not known."""


class Registry(dict):
    """``type name -> class`` for one family.

    Parameters
    ----------
    family : str
        What the entries are (``"material"``), for messages.
    base : type
        Every registered class must derive from it.
    """

    def __init__(self, family, base):
        super().__init__()
        self.family = family
        self.base = base

    def register(self, name_or_cls=None):
        """Register a class under a name; usable as ``@reg.register("name")`` or ``reg.register(cls)``.

        The name is stored on the class as ``type_name``. ``reg.register(cls)`` uses ``cls.type_name``.
        Registering a second class under a taken name is an error (re-registering the same class is not).
        """
        def add(cls, name):
            if not (isinstance(cls, type) and issubclass(cls, self.base)):
                raise RegistryError(f"{self.family} registry: {cls!r} is not a subclass of {self.base.__name__}")
            if not isinstance(name, str) or not name:
                raise RegistryError(f"{self.family} registry: {cls.__name__} needs a non-empty type name")
            if self.get(name, cls) is not cls:
                raise RegistryError(f"{self.family} registry: {name!r} is already {self[name].__name__}")
            cls.type_name = name
            self[name] = cls
            return cls

        if isinstance(name_or_cls, type):
            return add(name_or_cls, getattr(name_or_cls, "type_name", None))
        return lambda cls: add(cls, name_or_cls)

    def lookup(self, name, where=""):
        """The class registered as ``name``; a :class:`RegistryError` listing the known names otherwise."""
        try:
            return self[name]
        except (KeyError, TypeError):
            raise RegistryError(f"{where}{' ' if where else ''}unknown {self.family} type {name!r}; "
                                f"known: {', '.join(sorted(self))}") from None
