"""The architecture of DESIGN.md, checked from the source text (AST only; the docstring check imports pyrt).

What is checked:

(a) every import of a pyrt module points down :data:`LAYERS` (modules of one family may import each other);
(b) the pyrt import graph has no cycle;
(c) no pyrt import inside a function, method or class body (module level only; ``if TYPE_CHECKING:`` is
    module level, so it is allowed);
(d) ``embreex`` is imported only by ``pyrt/geometry/accel.py``;
(e) ``shaders/`` imports only numpy, math, numba (the formulas the compiled kernels share), the standard library
    and itself (relative imports);
(f) no module in ``pyrt/`` or ``shaders/`` is longer than :data:`MAX_LINES`;
(g) pyproject.toml installs exactly the packages under ``pyrt/`` plus ``pyrt.shaders``, never a top-level
    ``shaders``;
(h) the engine layers declare rather than probe: no ``getattr(x, "name")`` / ``hasattr(x, "name")`` with a
    constant name (but for :data:`PROBE_ALLOWLIST`) and no ``inspect.signature``.

:data:`KNOWN_VIOLATIONS` would list violations being removed (a check fails on a violation not in that list
*and* on a listed violation that no longer exists: the list can only shrink); it is empty.
"""
from __future__ import annotations

import ast
import inspect
import pathlib
import sys
import tomllib

import pytest

import pyrt

ROOT = pathlib.Path(__file__).resolve().parents[1]

#: The layer order, bottom first. Each layer is a list of module prefixes ("families"). A module may import
#: modules of a lower layer, and modules of its own family (same prefix); nothing else.
#: ``pyrt/__init__.py`` (the public API) and ``pyrt/__main__.py`` may import anything.
LAYERS = [
    ["pyrt.shaders"],
    ["pyrt.core"],
    ["pyrt.geometry"],
    ["pyrt.textures"],
    ["pyrt.materials"],
    ["pyrt.lights"],
    ["pyrt.scene"],
    ["pyrt.integrators"],
    ["pyrt.render"],
    ["pyrt.io"],
    ["pyrt.apps"],
]
EXEMPT = {"pyrt", "pyrt.__main__"}
#: Families that sit above the public API and may import it (``import pyrt``), as tools/ do.
PUBLIC_API_USERS = ["pyrt.apps"]

#: The engine layers, where (h) applies (paths relative to the repository root; a folder means every module
#: in it).
ENGINE = ["pyrt/core", "pyrt/geometry", "pyrt/textures", "pyrt/materials", "pyrt/lights", "pyrt/scene.py",
          "pyrt/integrators", "pyrt/render"]

MAX_LINES = 600

#: (file, attribute) -> why a constant-name getattr/hasattr is right there.
PROBE_ALLOWLIST = {
    ("pyrt/core/registry.py", "type_name"):
        "Registry.register(cls) reads the name a class being registered may declare (no base can declare it)",
    ("pyrt/scene.py", "uv"):
        "probes a trimesh visual: TextureVisuals has uv, ColorVisuals has not",
    ("pyrt/geometry/offsets.py", "__name__"):
        "names a user-supplied offset callable (functools.partial and callable objects have no __name__)",
}

#: Violations the code still has, each listed precisely (a check fails on any violation not listed *and* on a
#: listed one that no longer exists, so the list can only shrink). Empty: the restructuring removed them all.
KNOWN_VIOLATIONS = {
    "layers": set(),              # (importer module, imported module) pointing up the layer order
    "function_imports": set(),    # (file, enclosing function, imported pyrt module)
    "long_modules": {},           # file -> its length when listed
    "probes": {},                 # (file, "getattr" | "hasattr" | "inspect.signature", attribute) -> count
}


# ----------------------------------------------------------------------------------------------------------
# The scan


def _module_files():
    """``{module name: path}`` for every module of pyrt (``shaders/`` as ``pyrt.shaders``)."""
    out = {}
    for top, pkg in (("pyrt", "pyrt"), ("shaders", "pyrt.shaders")):
        for path in sorted((ROOT / top).rglob("*.py")):
            parts = list(path.relative_to(ROOT / top).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join([pkg, *parts])] = path
    return out


MODULES = _module_files()
TREES = {name: ast.parse(path.read_text(), filename=str(path)) for name, path in MODULES.items()}


def _rel(path):
    return path.relative_to(ROOT).as_posix()


def _is_package(name):
    return MODULES[name].name == "__init__.py"


def _walk_with_scope(tree):
    """Yield ``(node, enclosing function or class node or None)`` for every node."""
    stack = [(tree, None)]
    while stack:
        node, scope = stack.pop()
        yield node, scope
        inner = node if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef)) else scope
        stack.extend((child, inner) for child in ast.iter_child_nodes(node))


def _resolve(module, node):
    """The absolute module names an ``import`` / ``from ... import`` statement names (relative ones resolved).

    ``from pkg import name`` names ``pkg.name`` when that is a module, else ``pkg``.
    """
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    if node.level:
        base = module.split(".") if _is_package(module) else module.split(".")[:-1]
        base = base[:len(base) - (node.level - 1)]
        pkg = ".".join(base + ([node.module] if node.module else []))
    else:
        pkg = node.module
    return sorted({f"{pkg}.{a.name}" if f"{pkg}.{a.name}" in MODULES else pkg for a in node.names})


def _imports(module):
    """``[(imported module, statement node, enclosing scope)]`` for every import in ``module``."""
    return [(target, node, scope) for node, scope in _walk_with_scope(TREES[module])
            if isinstance(node, (ast.Import, ast.ImportFrom)) for target in _resolve(module, node)]


def _pyrt_target(name):
    """The pyrt module an imported name refers to (``pyrt.x.y`` or its longest known prefix), or None."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _layer(module):
    """``(layer index, family prefix)`` of a module."""
    for i, layer in enumerate(LAYERS):
        for prefix in layer:
            if module == prefix or module.startswith(prefix + "."):
                return i, prefix
    raise AssertionError(f"{module} is in no layer of LAYERS: add it there")


def _graph(module_level_only=False):
    """``{module: {pyrt modules it imports}}`` (only the imports run at import time if ``module_level_only``)."""
    graph = {m: set() for m in MODULES}
    for m in MODULES:
        for target, _, scope in _imports(m):
            t = _pyrt_target(target)
            if t is not None and t != m and not (module_level_only and scope is not None):
                graph[m].add(t)
    return graph


def _check_known(kind, found):
    """Compare what a check found with its ``KNOWN_VIOLATIONS`` entry; fail on new and on fixed ones."""
    known = KNOWN_VIOLATIONS[kind]
    if isinstance(known, dict):
        new = {k: v for k, v in found.items() if k not in known or v > known[k]}
        gone = {k: v for k, v in known.items() if k not in found or found[k] < v}
        msg_gone = "fixed (delete or lower them in KNOWN_VIOLATIONS)"
    else:
        new, gone = set(found) - set(known), set(known) - set(found)
        msg_gone = "fixed (delete them from KNOWN_VIOLATIONS)"
    lines = []
    if new:
        lines.append(f"new {kind} violation(s):\n" + "\n".join(f"  {v!r}" for v in sorted(new)))
    if gone:
        lines.append(f"{kind} violation(s) {msg_gone}:\n" + "\n".join(f"  {v!r}" for v in sorted(gone)))
    assert not lines, "\n".join(lines) + ("\ncurrent: " + repr(dict(sorted(found.items())) if isinstance(found, dict)
                                                               else sorted(found)))


# ----------------------------------------------------------------------------------------------------------
# (a) - (h)


def test_every_module_is_in_a_layer():
    for m in MODULES:
        if m not in EXEMPT:
            _layer(m)


def test_imports_point_down_the_layers():
    found = set()
    for m, deps in _graph().items():
        if m in EXEMPT:
            continue
        (li, fam) = _layer(m)
        for t in deps:
            if t in EXEMPT:  # the public API sits above the engine: only its users may import it
                if not (t == "pyrt" and any(m == p or m.startswith(p + ".") for p in PUBLIC_API_USERS)):
                    found.add((m, t))
                continue
            lt, ft = _layer(t)
            if lt > li or (lt == li and ft != fam):
                found.add((m, t))
    _check_known("layers", found)


def test_no_relative_imports_in_pyrt():
    bad = [f"{_rel(MODULES[m])}:{node.lineno}" for m in MODULES if not m.startswith("pyrt.shaders")
           for _, node, _ in _imports(m) if isinstance(node, ast.ImportFrom) and node.level]
    assert not bad, f"pyrt/ uses absolute 'pyrt.' imports only: {bad}"


def _find_cycle(graph):
    """One cycle of ``graph`` as a list of nodes (first == last), or None."""
    WHITE, GREY, BLACK = 0, 1, 2
    colour = dict.fromkeys(graph, WHITE)
    for start in sorted(graph):
        if colour[start] != WHITE:
            continue
        path, iters = [start], [iter(sorted(graph[start]))]
        colour[start] = GREY
        while path:
            nxt = next(iters[-1], None)
            if nxt is None:
                colour[path.pop()] = BLACK
                iters.pop()
            elif colour[nxt] == GREY:
                return path[path.index(nxt):] + [nxt]
            elif colour[nxt] == WHITE:
                colour[nxt] = GREY
                path.append(nxt)
                iters.append(iter(sorted(graph[nxt])))
    return None


def test_find_cycle_reports_the_cycle():
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b"}, "b": set()}) is None


def test_import_graph_has_no_cycle():
    """The imports run at import time form no cycle (imports inside functions are failures of
    :func:`test_pyrt_imports_are_at_module_level`, tracked there)."""
    cycle = _find_cycle(_graph(module_level_only=True))
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_pyrt_imports_are_at_module_level():
    found = set()
    for m in MODULES:
        for target, node, scope in _imports(m):
            if scope is not None and (_pyrt_target(target) is not None or getattr(node, "level", 0)):
                found.add((_rel(MODULES[m]), scope.name if not isinstance(scope, ast.Lambda) else "<lambda>",
                           _pyrt_target(target) or target))
    _check_known("function_imports", found)


def _third_party_imports(path):
    """Top-level names of every absolute import in a file (at any depth)."""
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module.split(".")[0]


def test_only_accel_imports_embreex():
    accel = ROOT / "pyrt/geometry/accel.py"
    assert "embreex" in set(_third_party_imports(accel))
    for top in ("pyrt", "shaders", "tools"):
        for path in (ROOT / top).rglob("*.py"):
            if path != accel:
                assert "embreex" not in set(_third_party_imports(path)), f"{_rel(path)} imports embreex"


def test_shaders_are_pure_numpy():
    allowed = {"numpy", "math", "numba", "__future__"} | set(sys.stdlib_module_names)
    for path in (ROOT / "shaders").rglob("*.py"):
        bad = set(_third_party_imports(path)) - allowed
        assert not bad, f"{_rel(path)} imports {sorted(bad)}: shaders/ imports only numpy, math, numba, the " \
                        "standard library and itself (relative imports)"
        assert not {"pyrt", "embreex", "trimesh"} & set(_third_party_imports(path))


def test_no_module_is_too_long():
    found = {}
    for path in MODULES.values():
        n = len(path.read_text().splitlines())
        if n > MAX_LINES:
            found[_rel(path)] = n
    _check_known("long_modules", found)


def test_pyproject_installs_exactly_the_packages():
    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    packages = cfg["packages"]
    assert len(packages) == len(set(packages)), f"duplicates in packages: {packages}"
    dirs = set()
    for top, pkg in (("pyrt", "pyrt"), ("shaders", "pyrt.shaders")):
        for d in [ROOT / top, *sorted(p for p in (ROOT / top).rglob("*") if p.is_dir())]:
            if d.name == "__pycache__" or not any(d.glob("*.py")):
                continue
            assert (d / "__init__.py").exists(), f"{_rel(d)} holds modules but no __init__.py"
            dirs.add(".".join([pkg, *d.relative_to(ROOT / top).parts]))
    assert set(packages) == dirs, (f"pyproject.toml packages {sorted(packages)} != package directories "
                                   f"{sorted(dirs)}; missing {sorted(dirs - set(packages))}, "
                                   f"extra {sorted(set(packages) - dirs)}")
    assert not any(p == "shaders" or p.startswith("shaders.") for p in packages), \
        "shaders/ is installed as pyrt.shaders, never as a top-level 'shaders' package"
    assert cfg["package-dir"] == {"pyrt.shaders": "shaders"}


def _engine_files():
    for entry in ENGINE:
        p = ROOT / entry
        if p.is_dir():
            yield from sorted(p.rglob("*.py"))
        elif p.exists():
            yield p


def _probes(path):
    """``{("getattr" | "hasattr" | "inspect.signature", attribute): count}`` for one file."""
    out = {}
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        key = None
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("getattr", "hasattr"):
            if len(node.args) >= 2 and isinstance(node.args[1], ast.Constant) and isinstance(node.args[1].value, str):
                key = (node.func.id, node.args[1].value)
        elif isinstance(node, ast.Attribute) and node.attr == "signature" and \
                isinstance(node.value, ast.Name) and node.value.id == "inspect":
            key = ("inspect.signature", "")
        elif isinstance(node, ast.ImportFrom) and node.module == "inspect" and \
                any(a.name == "signature" for a in node.names):
            key = ("inspect.signature", "")
        if key is not None:
            out[key] = out.get(key, 0) + 1
    return out


def test_engine_declares_rather_than_probes():
    found = {}
    for path in _engine_files():
        for (call, attr), n in _probes(path).items():
            if (_rel(path), attr) in PROBE_ALLOWLIST and call != "inspect.signature":
                continue
            found[(_rel(path), call, attr)] = n
    _check_known("probes", found)


def test_allowlists_are_current():
    """Every PROBE_ALLOWLIST entry still names a probe that exists (so stale excuses are removed)."""
    present = {(_rel(p), attr) for p in _engine_files() for (call, attr) in _probes(p) if call != "inspect.signature"}
    stale = set(PROBE_ALLOWLIST) - present
    assert not stale, f"PROBE_ALLOWLIST entries with no such probe any more: {sorted(stale)}"


@pytest.mark.parametrize("kind", sorted(KNOWN_VIOLATIONS))
def test_known_violations_are_listed_precisely(kind):
    """The known-violation entries name real files / modules (a typo would hide nothing, but mislead)."""
    files = {_rel(p) for p in MODULES.values()}
    for entry in KNOWN_VIOLATIONS[kind]:
        if kind == "layers":
            assert entry[0] in MODULES and entry[1] in MODULES, entry
        else:
            f = entry if isinstance(entry, str) else entry[0]
            assert f in files, entry


def test_every_public_name_and_method_has_a_docstring():
    """numpydoc's minimum: every name in ``pyrt.__all__`` and every public method or property of the public
    classes has a docstring (its own or the one it overrides)."""
    missing = []
    for name in pyrt.__all__:
        obj = getattr(pyrt, name)
        if not (inspect.isclass(obj) or inspect.isfunction(obj)):
            continue
        if not (inspect.getdoc(obj) or "").strip():
            missing.append(name)
        if not inspect.isclass(obj) or issubclass(obj, BaseException):
            continue
        for m in dir(obj):
            v = inspect.getattr_static(obj, m)
            if m.startswith("_") or not (isinstance(v, (property, classmethod, staticmethod)) or inspect.isfunction(v)):
                continue
            docs = [getattr(c.__dict__[m].fget if isinstance(c.__dict__[m], property)
                            else getattr(c.__dict__[m], "__func__", c.__dict__[m]), "__doc__", None)
                    for c in obj.__mro__ if m in c.__dict__]
            if not any((d or "").strip() for d in docs):
                missing.append(f"{name}.{m}")
    assert not missing, missing
