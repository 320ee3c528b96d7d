"""Scene files (TOML or JSON).

Format (every key optional unless marked; unknown keys are errors naming the table)::

    [camera]            # position, target, up, fov (degrees, vertical), width, height, spp
    [render]            # seed, background (RGB radiance), ambient (RGB radiance),
                        # shading_normal_fallback (bool, default true: see the README's conventions),
                        # integrator = "whitted" | "glossy" (or the table below)
    [render.integrator] # type = "whitted" | "glossy" and that integrator's options (pyrt.Whitted, pyrt.Glossy):
                        # max_depth, throughput_cutoff, roulette (bool: Russian roulette below the cutoff),
                        # offset (strategy name), transparent_shadows (bool),
                        # split_depth, light_select_depth; glossy also samples, depth, threshold, clamp
    [render.sampling]   # target_error, time_budget (s), max_spp, min_spp (adaptive rendering), sampler
                        # ("padded" | "independent": the camera hits' light and BSDF samples) (pyrt.Sampling)
    [render.execution]  # threads, backend ("auto" | "compiled" | "numpy"), parallel, chunk_samples
                        # The flat [render] keys of earlier releases (max_depth, glossy_samples, target_error, ...)
                        # still load, with a DeprecationWarning naming the table they belong in.
    [materials.NAME]    # type = "lambert" | "blinn_phong" | "mirror" | "glass" | ... ; the rest are the
                        # material constructor's keyword arguments (validated by it); a parameter
                        # may be a texture table, e.g. albedo = {type = "image", path = "wood.png"}
                        # (types in pyrt.textures.TEXTURES, paths relative to the scene file);
                        # normal_map = "normals.png" or {type = "normal_map", path = ..., strength = ...}
                        # coverage, any type: alpha_mode = "opaque" | "mask" | "blend", opacity (number or
                        # 1-channel texture, e.g. {type = "image", path = "leaf.png", select = 3, srgb = false}),
                        # alpha_cutoff (mask, default 0.5), double_sided (false: back faces culled)
    [[meshes]]          # file = "path" (relative to the scene file) OR primitive = "sphere" | "box" |
                        # "plane" | "cylinder"; material = NAME (required); transform: translate, rotate
                        # ([angle_deg, [x, y, z]] or a list of them), scale, or matrix (4x4);
                        # smooth = "auto" | true | false; shading = "flat" | "phong" | "gouraud"; name
                        # sphere: radius, subdivisions; box: extents; plane: size, normal;
                        # cylinder: radius, height, sections
    [[lights]]          # type = "point" | "spot" | "directional" | "projector" | "goniometric" | "ies" + that
                        # light's keyword arguments (image / profile paths relative to the scene file)
                        # area lights: type = "rect" (center, normal, size, tangent) | "disk" (center, normal,
                        # radius) | "sphere" (center, radius); radiance or power, color, n_samples, bsdf_samples;
                        # visible = true adds the emitting mesh (seen by camera rays);
                        # type = "emissive_mesh" (n_samples, selection, min_power, name): the emissive meshes
                        # above as a light (an error when none of them emits)
    [environment]       # type = "constant" (color) | "latlong" (file: EXR or .hdr, relative to the scene file) |
                        # "cube" (file: cross image, or faces = [6 files]) | "sky" (procedural: sun_direction,
                        # sun_angle, sun_radiance, zenith, horizon, ground, width, height);
                        # intensity, rotate ([angle_deg, [x, y, z]] or a list), filter, hide_background,
                        # background; lighting = "mis" | "map" | "bsdf" | "cosine" | "uniform" | "preview" |
                        # false (background only), samples (default 4), heuristic ("power" | "balance"),
                        # preview_samples; mis only: bsdf_samples (default = samples), compensate (default
                        # true: MIS-compensated map samples); control_variate (default false; true: Lambertian
                        # hits on flat faces get the exact unshadowed irradiance, samples only the shadows)

The same structure as a Python dict (Mitsuba's ``mi.load_dict`` idea) goes to :func:`load_dict`;
:func:`load_scene` parses a file and calls it.

Example: ``assets/default_scene.toml``.
"""
from __future__ import annotations

import inspect
import json
import math
import os
import tomllib
import warnings

import numpy as np

from pyrt.core.camera import Camera
from pyrt.core.errors import Error
from pyrt.lights import LIGHTS, PATH_ARGUMENTS as LIGHT_PATH_ARGUMENTS
from pyrt.lights import environment as _env
from pyrt.lights.environment_light import set_environment
from pyrt.materials import REGISTRY as MATERIALS
from pyrt.geometry.offsets import STRATEGIES
from pyrt.render import INTEGRATORS, SAMPLERS
from pyrt.render import settings
from pyrt.core.errors import RenderError
from pyrt.core import checks
from pyrt.core.transforms import align_vectors
from pyrt.scene import Scene, plane_quad, transform_matrix
from pyrt.textures import TextureError, texture_from_dict


class SceneFileError(Error, ValueError):
    """A scene file is malformed; the message names the file and the offending table/key."""


class SceneFileNotFoundError(SceneFileError, FileNotFoundError):
    """The scene file does not exist."""


_CAMERA_KEYS = {"position", "target", "up", "fov", "width", "height", "spp", "jitter"}
_RENDER_OPTIONS = ("max_depth", "seed", "throughput_cutoff", "roulette", "offset", "transparent_shadows", "integrator",
                   "glossy_samples", "glossy_depth", "glossy_threshold", "sampler",
                   "target_error", "time_budget", "max_spp", "min_spp")
#: the option tables of [render] and the keys each takes (pyrt.render.settings: the same names as in Python)
_RENDER_TABLES = {"integrator": {"type", "max_depth", "throughput_cutoff", "roulette", "offset", "transparent_shadows",
                                 "split_depth", "light_select_depth", "samples", "depth", "threshold", "clamp"},
                  "sampling": {"target_error", "time_budget", "max_spp", "min_spp", "sampler"},
                  "execution": {"threads", "backend", "parallel", "chunk_samples"}}
_RENDER_KEYS = {"background", "ambient", "shading_normal_fallback", "sampling", "execution", *_RENDER_OPTIONS}
_MESH_COMMON = {"file", "primitive", "material", "translate", "rotate", "scale", "matrix", "smooth", "name",
                "crease_angle", "shading"}
_PRIMITIVE_KEYS = {"sphere": {"radius", "subdivisions"}, "box": {"extents"}, "plane": {"size", "normal"},
                   "cylinder": {"radius", "height", "sections"}}
#: material keys every type accepts: coverage (Material.set_coverage)
_COVERAGE_KEYS = ("opacity", "alpha_mode", "alpha_cutoff", "double_sided")
_TOP_KEYS = {"camera", "render", "materials", "meshes", "lights", "environment"}
_ENV_COMMON = {"type", "intensity", "rotate", "hide_background", "background", "lighting", "samples", "heuristic",
               "preview_samples", "name", "bsdf_samples", "compensate", "control_variate"}
_ENV_KEYS = {"constant": {"color"}, "latlong": {"file", "filter"}, "cube": {"file", "faces", "filter"},
             "sky": {"sun_direction", "sun_angle", "sun_radiance", "zenith", "horizon", "ground", "width", "height",
                     "filter"}}


def _check_keys(where, table, allowed, path):
    if not isinstance(table, dict):
        raise SceneFileError(f"{path}: {where} must be a table, got {type(table).__name__}")
    unknown = set(table) - set(allowed)
    if unknown:
        raise SceneFileError(f"{path}: unknown key(s) {sorted(unknown)} in {where}; allowed: {sorted(allowed)}")


def _array_of_tables(data, key, path):
    """``data[key]`` (default empty), which must be a list: ``[[meshes]]`` in TOML, a JSON array of objects."""
    items = data.get(key, [])
    if not isinstance(items, list):
        got = "a single table" if isinstance(items, dict) else type(items).__name__
        raise SceneFileError(f"{path}: {key} must be an array of tables ([[{key}]] in TOML, a list in JSON/dicts), "
                             f"got {got}" + (f" ([{key}] in TOML)" if isinstance(items, dict) else ""))
    return items


def _typed(spec, registry, what, where, path):
    """A table with a ``type`` from ``registry`` -> ``(type, the other keys)``; errors name the table."""
    if not isinstance(spec, dict) or "type" not in spec:
        raise SceneFileError(f"{path}: {where} needs a 'type' (one of {sorted(registry)})")
    kind = spec["type"]
    if kind not in registry:
        raise SceneFileError(f"{path}: {where}: unknown {what} type {kind!r}; choose one of {sorted(registry)}")
    return kind, {k: v for k, v in spec.items() if k != "type"}


def _construct(cls, kwargs, where, path):
    try:
        return cls(**kwargs)
    except TypeError as e:
        sig = inspect.signature(cls.__init__)
        allowed = [p for p in sig.parameters if p != "self"]
        raise SceneFileError(f"{path}: {where}: {e}; allowed parameters: {allowed}") from None
    except ValueError as e:
        raise SceneFileError(f"{path}: {where}: {e}") from None


#: how each numeric [render] option is checked: (checks function, its keyword arguments)
_RENDER_NUMBERS = {"max_depth": (checks.integer, {"lo": 0}), "seed": (checks.integer, {"lo": 0}),
                   "throughput_cutoff": (checks.finite_number, {"lo": 0.0}),
                   "glossy_samples": (checks.integer, {"lo": 1}), "glossy_depth": (checks.integer, {"lo": 0}),
                   "glossy_threshold": (checks.finite_number, {"lo": 0.0}),
                   "target_error": (checks.finite_number, {"lo": 0.0}), "time_budget": (checks.finite_number, {"lo": 0.0}),
                   "max_spp": (checks.integer, {"lo": 1}), "min_spp": (checks.integer, {"lo": 1})}
#: the largest icosphere subdivision level a scene file may ask for (level 8: 1.3 M triangles)
MAX_SUBDIVISIONS = 8


def _render_options(rnd, path):
    """The ``[render]`` keys that are :func:`pyrt.render` arguments, each checked here whatever integrator or path
    would read it (an unused ``glossy_samples = -1`` is still an error naming the key and the file)."""
    options = {k: rnd[k] for k in _RENDER_OPTIONS if k in rnd}
    for key, (check, kw) in _RENDER_NUMBERS.items():
        if key in options:
            options[key] = check(f"{path}: [render]", key, options[key], SceneFileError, **kw)
    for key in ("transparent_shadows", "roulette"):
        if key in options and not isinstance(options[key], bool):
            raise SceneFileError(f"{path}: [render] {key} must be true or false, got {options[key]!r}")
    for key in ("target_error", "time_budget"):
        if key in options and options[key] <= 0:
            raise SceneFileError(f"{path}: [render] {key} must be > 0, got {options[key]!r}")
    if "offset" in options and (not isinstance(options["offset"], str) or options["offset"] not in STRATEGIES):
        raise SceneFileError(f"{path}: [render] offset must be one of {sorted(STRATEGIES)}, got {options['offset']!r}")
    if "min_spp" in options and options["min_spp"] % 2:
        raise SceneFileError(f"{path}: [render] min_spp must be even (two half-buffers), got {options['min_spp']}")
    if "integrator" in options and options["integrator"] not in INTEGRATORS:
        raise SceneFileError(f"{path}: [render] integrator must be one of {list(INTEGRATORS)}, "
                             f"got {options['integrator']!r}")
    if "sampler" in options and options["sampler"] not in SAMPLERS:
        raise SceneFileError(f"{path}: [render] sampler must be one of {list(SAMPLERS)}, got {options['sampler']!r}")
    return options


def _grouped_options(rnd, path):
    """The ``[render]`` table's render options as :func:`pyrt.render` arguments: ``seed`` and one dict per option
    table (``integrator``, ``sampling``, ``execution``), each checked by its class in :mod:`pyrt.render.settings` and
    the per-name checks of :func:`_render_options`. Flat keys of earlier releases move into their table, with a
    DeprecationWarning naming it."""
    flat = {k: v for k, v in rnd.items() if k in _RENDER_OPTIONS and k not in ("seed", "integrator")}
    tables = {}
    integ = rnd.get("integrator")
    if isinstance(integ, dict) or integ is None:
        tables["integrator"] = dict(integ or {})
    else:
        tables["integrator"] = {"type": integ}
    for name in ("sampling", "execution"):
        tables[name] = dict(rnd.get(name) or {})
    for name, table in tables.items():
        _check_keys(f"[render.{name}]", table, _RENDER_TABLES[name], path)
    inverse = {v: k for k, v in settings.LEGACY.items()}
    checked = {"seed": rnd["seed"]} if "seed" in rnd else {}
    for name, table in tables.items():      # the per-name checks, under the flat names they were written for
        checked.update({inverse.get((name, k), k): v for k, v in table.items() if k != "type"})
    if "type" in tables["integrator"]:
        checked["integrator"] = tables["integrator"]["type"]
    checked.update(flat)
    checked = _render_options(checked, path)
    if flat:
        moved = ", ".join(f"{k} -> [render.{settings.LEGACY[k][0]}] {settings.LEGACY[k][1]}" for k in flat)
        warnings.warn(f"deprecated scene-file render keys in {path}: {moved}", DeprecationWarning, stacklevel=4)
    for key in flat:
        group, name = settings.LEGACY[key]
        if group == "integrator" and name in ("samples", "depth", "threshold", "clamp") \
                and tables["integrator"].get("type", "whitted") == "whitted":
            continue        # earlier releases accepted (and checked) the glossy options beside whitted
        tables[group][name] = checked[key]
    options = {"seed": checked["seed"]} if "seed" in checked else {}
    try:
        settings.integrator_from(tables["integrator"])
        for name in ("sampling", "execution"):
            settings.group_from(name, tables[name])
    except RenderError as e:
        raise SceneFileError(f"{path}: [render] {e}") from None
    options.update({name: table for name, table in tables.items() if table})
    return options


def _positive(params, key, default, where, path):
    """``params[key]`` (else ``default``) as a finite float > 0, else a SceneFileError naming the key."""
    v = params.get(key, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise SceneFileError(f"{path}: {where}: {key} must be a finite number > 0, got {v!r}")
    return float(v)


def _primitive(kind, params, where, path):
    import trimesh  # deferred (pyrt.core.transforms)
    if kind == "sphere":
        sub = params.get("subdivisions", 4)
        checks.integer(f"{path}: {where}", "subdivisions", sub, SceneFileError, lo=0)
        if sub > MAX_SUBDIVISIONS:
            raise SceneFileError(f"{path}: {where}: subdivisions must be at most {MAX_SUBDIVISIONS} "
                                 f"({20 * 4 ** MAX_SUBDIVISIONS} triangles), got {sub!r}")
        radius = _positive(params, "radius", 1.0, where, path)
        m = trimesh.creation.icosphere(subdivisions=int(sub), radius=1.0)     # scaled here: trimesh's radius= gave
        m.apply_scale(radius)                                                 # NaN vertices for a tiny radius
        return m, True
    if kind == "box":
        ext = checks.numbers_array(f"{path}: {where}", "extents", params.get("extents", (1.0, 1.0, 1.0)),
                                   SceneFileError)
        if ext.shape != (3,) or not np.all(np.isfinite(ext)) or np.any(ext <= 0):
            raise SceneFileError(f"{path}: {where}: extents must be 3 finite numbers > 0, got {params['extents']!r}")
        return trimesh.creation.box(extents=ext), False
    if kind == "plane":
        size = checks.numbers_array(f"{path}: {where}", "size", params.get("size", 1.0), SceneFileError)
        if size.shape not in ((), (2,)) or not np.all(np.isfinite(size)) or np.any(size <= 0):
            raise SceneFileError(f"{path}: {where}: size must be a finite number > 0 or two of them, "
                                 f"got {params['size']!r}")
        sx, sz = np.broadcast_to(size, (2,))
        v, f, uv = plane_quad(sx, sz)
        m = trimesh.Trimesh(vertices=v, faces=f, process=False)
        m.visual = trimesh.visual.TextureVisuals(uv=uv)
        nrm = np.asarray(params.get("normal", (0, 1, 0)), dtype=np.float64)
        if nrm.shape != (3,) or np.linalg.norm(nrm) == 0:
            raise SceneFileError(f"{path}: {where}: plane normal must be a non-zero 3-vector")
        m.apply_transform(align_vectors([0, 1, 0], nrm / np.linalg.norm(nrm)))
        return m, False
    if kind == "cylinder":
        sections = params.get("sections", 64)
        checks.integer(f"{path}: {where}", "sections", sections, SceneFileError, lo=3)
        return trimesh.creation.cylinder(radius=_positive(params, "radius", 0.5, where, path),
                                         height=_positive(params, "height", 1.0, where, path),
                                         sections=int(sections)), "auto"
    raise SceneFileError(f"{path}: {where}: unknown primitive {kind!r}; choose one of {sorted(_PRIMITIVE_KEYS)}")


def _texture(spec, where, base, path):
    """A texture from an inline table ``{type = "image" | "checker" | ..., ...}`` (pyrt.textures)."""
    try:
        return texture_from_dict(spec, base_dir=base)
    except (TextureError, TypeError, ValueError) as e:
        raise SceneFileError(f"{path}: {where}: {e}") from None


def load_scene(path):
    """Load a TOML or JSON scene file into a :class:`pyrt.Scene`.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.toml`` or ``.json`` file (the format in this module's docstring). Paths inside it (meshes,
        textures, light images and profiles, environment maps) are relative to the file's folder.

    Returns
    -------
    scene : pyrt.Scene
    render_options : dict
        The arguments of :func:`pyrt.render` the file's ``[render]`` table gives: ``seed`` and the option tables
        ``integrator`` / ``sampling`` / ``execution`` as dicts (``pyrt.render(scene, **render_options)``).

    Raises
    ------
    SceneFileNotFoundError
        ``path`` does not exist (a :class:`SceneFileError` and a ``FileNotFoundError``).
    SceneFileError
        The file cannot be parsed or describes no valid scene; the message names the file and the key.

    See Also
    --------
    load_dict : the same from a dict.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise SceneFileNotFoundError(f"scene file not found: {path}")
    try:
        with open(path, "rb") as f:
            if path.endswith(".json"):
                data = json.load(f)
            else:
                data = tomllib.load(f)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as e:
        raise SceneFileError(f"{path}: cannot parse: {e}") from None
    return _load(data, os.path.dirname(os.path.abspath(path)), path)


def load_dict(spec, *, base_dir=None):
    """Build a :class:`pyrt.Scene` from a dict with the structure of a scene file.

    The keys are the tables of a scene file (this module's docstring): ``camera``, ``render``,
    ``materials`` (name -> ``{"type": ..., parameters}``), ``meshes`` and ``lights`` (lists of dicts),
    ``environment``. Types are looked up in the family registries (``pyrt.materials.REGISTRY``,
    ``pyrt.lights.REGISTRY``, ``pyrt.lights.environment.ENVIRONMENTS``, textures through
    :func:`pyrt.textures.texture_from_dict`). Values may be lists, tuples or arrays. ``spec`` is not
    modified.

    Parameters
    ----------
    spec : dict
        The scene description.
    base_dir : str or os.PathLike, optional
        Folder that relative paths in ``spec`` (mesh files, texture images, light images and profiles,
        environment maps) are resolved against. Default: the current working directory at the call.

    Returns
    -------
    scene : pyrt.Scene
    render_options : dict
        The arguments of :func:`pyrt.render` the file's ``[render]`` table gives: ``seed`` and the option tables
        ``integrator`` / ``sampling`` / ``execution`` as dicts (``pyrt.render(scene, **render_options)``).

    Raises
    ------
    SceneFileError
        An unknown key or type, a missing required key, a file not found or a parameter refused by its
        constructor; the message names the table and key (``[materials.red]``, ``[[meshes]] #0`` ...).

    See Also
    --------
    load_scene : the same from a TOML or JSON file.

    Examples
    --------
    >>> import pyrt
    >>> scene, options = pyrt.load_dict({
    ...     "camera": {"position": [0, 1, 4], "target": [0, 0.5, 0], "width": 64, "height": 48},
    ...     "render": {"seed": 1},
    ...     "materials": {"red": {"type": "lambert", "albedo": [0.8, 0.2, 0.2]}},
    ...     "meshes": [{"primitive": "sphere", "radius": 0.5, "translate": [0, 0.5, 0], "material": "red"}],
    ...     "lights": [{"type": "point", "position": [2, 3, 2], "intensity": 20.0}],
    ... })
    >>> image = pyrt.render(scene, spp=1, **options)
    >>> image.shape
    (48, 64, 3)
    """
    base = os.path.abspath(os.fspath(base_dir) if base_dir is not None else os.getcwd())
    return _load(spec, base, "scene dict")


def _load(data, base, path):
    """:func:`load_dict` with the label ``path`` that starts every error message."""
    import trimesh  # deferred (pyrt.core.transforms)
    _check_keys("the top level", data, _TOP_KEYS, path)
    cam_t = data.get("camera", {})
    _check_keys("[camera]", cam_t, _CAMERA_KEYS, path)
    camera = _construct(Camera, cam_t, "[camera]", path)
    rnd = data.get("render", {})
    _check_keys("[render]", rnd, _RENDER_KEYS, path)
    scene = _construct(Scene, {"camera": camera, **{k: rnd[k] for k in ("background", "ambient",
                                                                       "shading_normal_fallback") if k in rnd}},
                       "[render]", path)
    options = _grouped_options(rnd, path)

    materials = {}
    mats_t = data.get("materials", {})
    if not isinstance(mats_t, dict):
        raise SceneFileError(f"{path}: [materials] must be a table of named materials")
    for name, spec in mats_t.items():
        where = f"[materials.{name}]"
        kind, kwargs = _typed(spec, MATERIALS, "material", where, path)
        kwargs.setdefault("name", name)
        normal_map = kwargs.pop("normal_map", None)
        kwargs = {k: _texture(v, f"{where}.{k}", base, path) if isinstance(v, dict) else v for k, v in kwargs.items()}
        cover = {k: kwargs.pop(k) for k in _COVERAGE_KEYS if k in kwargs}
        materials[name] = _construct(MATERIALS[kind], kwargs, where, path)
        if cover:   # any material: Material.set_coverage (pyrt.integrators.coverage)
            try:
                materials[name].set_coverage(**cover)
            except Error as exc:
                raise SceneFileError(f"{path}: {where}: {exc}") from None
        if normal_map is not None:
            if not isinstance(normal_map, (str, dict)):
                raise SceneFileError(f"{path}: {where}.normal_map must be an image path or a texture table, "
                                     f"got {normal_map!r}")
            spec_nm = {"type": "normal_map", "path": normal_map} if isinstance(normal_map, str) else normal_map
            materials[name].normal_map = _texture(spec_nm, f"{where}.normal_map", base, path)

    for i, spec in enumerate(_array_of_tables(data, "meshes", path)):
        where = f"[[meshes]] #{i}" + (f" ({spec.get('name')})" if isinstance(spec, dict) and "name" in spec else "")
        if not isinstance(spec, dict):
            raise SceneFileError(f"{path}: {where} must be a table")
        prim = spec.get("primitive")
        if prim is not None and (not isinstance(prim, str) or prim not in _PRIMITIVE_KEYS):
            raise SceneFileError(f"{path}: {where}: unknown primitive {prim!r}; choose one of {sorted(_PRIMITIVE_KEYS)}")
        allowed = _MESH_COMMON | _PRIMITIVE_KEYS.get(prim, set())
        _check_keys(where, spec, allowed, path)
        if ("file" in spec) == (prim is not None):
            raise SceneFileError(f"{path}: {where}: give exactly one of 'file' or 'primitive'")
        if "material" not in spec:
            raise SceneFileError(f"{path}: {where}: missing 'material'")
        if spec["material"] not in materials:
            raise SceneFileError(f"{path}: {where}: unknown material {spec['material']!r}; defined: {sorted(materials)}")
        smooth_default = "auto"
        if prim is not None:
            try:
                mesh, smooth_default = _primitive(prim, spec, where, path)
            except SceneFileError:
                raise
            except (ValueError, TypeError, IndexError, OverflowError) as e:  # trimesh.creation on bad sizes
                raise SceneFileError(f"{path}: {where}: invalid {prim} parameters: {type(e).__name__}: {e}") from None
        else:
            fpath = spec["file"] if os.path.isabs(spec["file"]) else os.path.join(base, spec["file"])
            if not os.path.exists(fpath):
                raise SceneFileError(f"{path}: {where}: mesh file not found: {fpath}")
            try:  # unprocessed first: processing drops the faces of NaN vertices without a word
                mesh = trimesh.load(fpath, force="mesh", process=False)
            except Exception as e:  # trimesh raises many types
                raise SceneFileError(f"{path}: {where}: cannot load mesh file {fpath}: {e}") from None
            if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
                raise SceneFileError(f"{path}: {where}: mesh file {fpath}: no triangles found")
            if not np.all(np.isfinite(mesh.vertices)):
                bad = int(np.flatnonzero(~np.all(np.isfinite(mesh.vertices), axis=1))[0])
                raise SceneFileError(f"{path}: {where}: mesh file {fpath}: vertex {bad + 1} is not finite "
                                     f"({mesh.vertices[bad].tolist()})")
            mesh.process()  # what trimesh.load(process=True) does: merge vertices (same mesh as before)
        try:
            tf = transform_matrix(translate=spec.get("translate"), rotate=spec.get("rotate"),
                                  scale=spec.get("scale"), matrix=spec.get("matrix"))
            scene.add_mesh(mesh, materials[spec["material"]], transform=tf, smooth=spec.get("smooth", smooth_default),
                           crease_angle=spec.get("crease_angle", 30.0), name=spec.get("name", f"mesh{i}"),
                           shading=spec.get("shading"))
        except ValueError as e:
            raise SceneFileError(f"{path}: {where}: {e}") from None

    for i, spec in enumerate(_array_of_tables(data, "lights", path)):
        where = f"[[lights]] #{i}"
        kind, kwargs = _typed(spec, LIGHTS, "light", where, path)
        for k in LIGHT_PATH_ARGUMENTS:  # image / IES files relative to the scene file
            if isinstance(kwargs.get(k), str) and not os.path.isabs(kwargs[k]):
                kwargs[k] = os.path.join(base, kwargs[k])
        if LIGHTS[kind].scene_emitter:       # the emissive meshes loaded above (Scene.add_emissive_lights)
            try:
                added = scene.add_emissive_lights(**kwargs)
            except TypeError as e:
                raise SceneFileError(f"{path}: {where}: {e}; allowed parameters: "
                                     "['n_samples', 'selection', 'min_power', 'name']") from None
            except ValueError as e:
                raise SceneFileError(f"{path}: {where}: {e}") from None
            if added is None and "min_power" not in kwargs:     # asked for, and nothing to light with
                raise SceneFileError(f"{path}: {where}: type {kind!r}: no mesh above emits light (no material with "
                                     "emission, or its emission is 0): the light would add nothing")
            continue
        visible = kwargs.pop("visible", True) if LIGHTS[kind].has_mesh else None
        light = _construct(LIGHTS[kind], kwargs, where, path)
        if visible is None:
            scene.add_light(light)
        else:
            light.add_to(scene, visible=bool(visible))
    if "environment" in data:
        _load_environment(data["environment"], scene, base, path)
    return scene, options


def _load_environment(spec, scene, base, path):
    """The ``[environment]`` table -> ``scene.environment`` (+ an EnvironmentLight unless lighting = false)."""
    where = "[environment]"
    if not isinstance(spec, dict) or not isinstance(spec.get("type"), str) or spec["type"] not in _ENV_KEYS:
        raise SceneFileError(f"{path}: {where} needs a 'type' (one of {sorted(_ENV_KEYS)})")
    kind = spec["type"]
    _check_keys(where, spec, _ENV_COMMON | _ENV_KEYS[kind], path)

    def rel(p):
        if not isinstance(p, str):
            raise SceneFileError(f"{path}: {where}: file paths must be strings, got {p!r}")
        full = p if os.path.isabs(p) else os.path.join(base, p)
        if not os.path.exists(full):
            raise SceneFileError(f"{path}: {where}: file not found: {full}")
        return full

    common = {k: spec[k] for k in ("intensity", "rotate", "hide_background", "background", "name") if k in spec}
    if kind == "constant":
        env = _construct(_env.ENVIRONMENTS["constant"], {"color": spec.get("color", 1.0), **common}, where, path)
    elif kind == "latlong":
        if "file" not in spec:
            raise SceneFileError(f"{path}: {where}: type 'latlong' needs 'file'")
        env = _construct(_env.ENVIRONMENTS["latlong"], {"image": rel(spec["file"]), **common,
                                                   **({"filter": spec["filter"]} if "filter" in spec else {})},
                         where, path)
    elif kind == "cube":
        if ("file" in spec) == ("faces" in spec):
            raise SceneFileError(f"{path}: {where}: type 'cube' needs exactly one of 'file' (cross) or 'faces'")
        faces = rel(spec["file"]) if "file" in spec else [rel(f) for f in spec["faces"]]
        env = _construct(_env.ENVIRONMENTS["cube"], {"faces": faces, **common,
                                                   **({"filter": spec["filter"]} if "filter" in spec else {})},
                         where, path)
    else:
        sky_kw = {k: spec[k] for k in _ENV_KEYS["sky"] - {"filter"} if k in spec}
        try:
            img = _env.procedural_sky(**sky_kw)
        except (TypeError, ValueError) as e:
            raise SceneFileError(f"{path}: {where}: {e}") from None
        env = _construct(_env.ENVIRONMENTS["latlong"], {"image": img, **common,
                                                   **({"filter": spec["filter"]} if "filter" in spec else {})},
                         where, path)
    lighting = spec.get("lighting", "mis")
    try:
        given = {"samples": "n_samples", "bsdf_samples": "bsdf_samples", "compensate": "compensate",
                 "control_variate": "control_variate"}
        split = {kw: spec[k] for k, kw in given.items() if k in spec}   # else set_environment's defaults
        set_environment(scene, env, lighting=lighting, heuristic=spec.get("heuristic", "power"),
                        preview_samples=spec.get("preview_samples", 16), **split)
    except ValueError as e:
        raise SceneFileError(f"{path}: {where}: {e}") from None
