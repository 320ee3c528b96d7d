"""What the A/B tools run first in a child process to import pyrt from another checkout.

``TREE_PREAMBLE`` is Python source: it puts the checkout ``sys.argv[1]`` first on ``sys.path`` and makes
``import pyrt.shaders`` load that checkout's top-level ``shaders/`` (an editable install maps ``pyrt.shaders`` to
its own checkout, so without this both trees of an A/B would run the same kernels; submodules follow the package's
``__path__``). Used by ``ab_trees.py``, ``ab_asset.py``, ``ab_preview.py`` and ``bench_kinds.py``.
"""

TREE_PREAMBLE = r'''
import importlib.util, os, sys
_TREE = os.path.abspath(sys.argv[1])


class _TreeShaders:
    """``pyrt.shaders`` from the tree's shaders/."""

    @staticmethod
    def find_spec(name, path=None, target=None):
        """The spec of the tree's shaders package for ``pyrt.shaders``, None for every other module."""
        if name != "pyrt.shaders":
            return None
        d = os.path.join(_TREE, "shaders")
        return importlib.util.spec_from_file_location(name, os.path.join(d, "__init__.py"),
                                                      submodule_search_locations=[d])


sys.meta_path.insert(0, _TreeShaders)
sys.path.insert(0, _TREE)
'''
