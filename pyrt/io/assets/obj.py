"""OBJ + MTL -> :class:`Asset` (geometry read by trimesh, materials parsed here).

OBJ + MTL mapping (documented choice; the MTL "illum 2" model *is* Blinn-Phong)
------------------------------------------------------------------------------
- Opaque materials -> :class:`~pyrt.io.assets.materials.ObjMaterial` = energy-normalised :class:`pyrt.BlinnPhong`:
  ``kd = Kd`` (times ``map_Kd``, sRGB), ``ks = Ks``, ``exponent = Ns``; if ``kd + ks > 1`` in a
  channel, ``ks`` is scaled down uniformly (warning) so the model conserves energy.
  ``Ke`` (and ``map_Ke``) is emitted radiance. ``Ka`` is not used (pyrt's ambient term uses the
  albedo ``kd``).
- Glass (``illum`` 4, 6, 7, 9) -> :class:`pyrt.Glass` with ``ior = Ni`` (1.5 if ``Ni <= 1`` or absent, warning)
  and ``tint = Tf`` (default white).
- Dissolve (``d < 1``, ``Tr > 0``, ``map_d``; the MTL spec's "dissolve", not refraction) -> coverage: the
  material's ``opacity = d x map_d`` with ``alpha_mode = "blend"`` (straight-through transparency, shadows
  included; :mod:`pyrt.integrators.coverage`). ``map_d`` reads the channel ``-imfchan`` names (r, g, b), else the
  image's alpha channel if it has one, else its first (grey) channel; linear, MIP-filtered like every map.
- A missing MTL file (``mtllib``) or texture file (``map_Kd``, ``map_Ke``, ``map_d``, ``norm``) is a substitution, not an
  error (:attr:`Asset.substitutions`, also a warning): the default material, or the material without that map
  (``Kd`` alone), is used. A file that exists but cannot be read is an error naming it.
- Files named by the OBJ (``mtllib``) and the MTL (``map_Kd``, ``map_Ke``, ``norm``) are read only if they are
  regular files: relative paths from the naming file's folder (``..`` allowed: model packs share texture folders)
  or absolute paths (exporters write them). They are read as an MTL or decoded as an image, nothing else.
- A vertex with a NaN or infinite coordinate is an error naming its line (trimesh would drop its faces).
- ``map_Kd`` options ``-s`` and ``-o`` become the texture's UV scale and offset; ``norm`` is used as
  a normal map. ``bump`` / ``map_Bump`` name a height map in the MTL spec, but exporters (Blender's among them)
  write tangent-space normal maps there: an RGB image that looks like one (mean blue >= 0.6, mean red and green
  within 0.5 +- 0.15) is read as the normal map (``-bm`` its strength), with a warning saying so, unless ``norm``
  gives one; a height map is ignored with a warning, as are other maps.
- The exporters' PBR extension (``Pr`` roughness, ``Pm`` metallic, ``map_Pr``, ``map_Pm``; Blender writes it with
  "PBR extensions" on): a block using it becomes the glTF metallic-roughness material (base colour ``Kd x
  map_Kd``, metallic ``map_Pm`` else ``Pm`` (default 0), roughness ``map_Pr`` else ``Pr`` (default 0.5): a map
  replaces its scalar, as Blender's importer reads them; ``Ke``, the normal map), not Blinn-Phong; ``Ks`` and
  ``Ns`` are then not used.
"""
from __future__ import annotations

import functools
import io
import os
import re

import numpy as np

from pyrt.textures import ImageTexture, NormalMap, TextureError, load_image
from pyrt.io.assets.common import AssetError, MTLParams, colour_texels, trimesh_load, vertex_colors
from pyrt.io.assets.texture_budget import reduce_texels, reduction_factor
from pyrt.io.assets.asset import Asset, AssetInstance, AssetMesh
from pyrt.io.assets.find_file import find_file
from pyrt.io.assets.materials import mtl_is_transparent, mtl_kd_ks


_MTL_OPTS = {"-blendu": 1, "-blendv": 1, "-bm": 1, "-boost": 1, "-cc": 1, "-clamp": 1, "-imfchan": 1,
             "-mm": 2, "-texres": 1, "-type": 1, "-o": 3, "-s": 3, "-t": 3}


def colour_map(fname, base, what, *, warnings, substitutions=None, max_texture=None):
    """A colour (sRGB) texture read from the file a model names ``fname`` as MTL's ``map_Kd`` is: found by
    :func:`~pyrt.io.assets.find_file.find_file` from ``base``, reduced to ``max_texture``, grey images as RGB; None
    when the file does not exist and ``substitutions`` (a list) is given (a message is appended to it), else an
    :class:`AssetError`. Other formats' texture references (a PLY's ``comment TextureFile``) read it this way."""
    return _mtl_map([fname], base, what, srgb=True, warnings=warnings, substitutions=substitutions,
                    max_texture=max_texture)


def _mtl_map(tokens, base, what, *, srgb, warnings, normal=False, alpha=False, cache=None, substitutions=None,
             max_texture=None):
    """Parse ``map_* [options] file`` -> texture; a missing file is an AssetError, or, when a ``substitutions``
    list is given, a message appended to it and None (the map is left out: its factor alone is used).

    ``cache`` (a dict, one per load) maps ``(real path, decoding)`` to the first texture read from that
    file: later maps of the same file share its decoded texels and lazy MIP pyramid. Grey and grey + alpha
    images are read as RGB(A) (:func:`~pyrt.io.assets.common.colour_texels`). Colour and normal maps longer than
    ``max_texture`` are reduced as they are decoded (:mod:`pyrt.io.assets.texture_budget`, a warning each).
    """
    opts, i = {}, 0
    while i < len(tokens) and tokens[i] in _MTL_OPTS:
        k = tokens[i]
        n = _MTL_OPTS[k]
        vals = []
        i += 1
        while len(vals) < n and i < len(tokens):
            try:
                vals.append(float(tokens[i]))
            except ValueError:
                if k in ("-o", "-s", "-t") and vals:
                    break
                vals.append(tokens[i])
            i += 1
        opts[k] = vals
    fname = " ".join(tokens[i:])
    if not fname:
        raise AssetError(f"{what}: no file name")
    fpath, how = find_file(base, fname)
    if fpath is None:
        named = fname if os.path.isabs(fname) else os.path.join(base, fname.replace("\\", "/"))
        if substitutions is None:
            raise AssetError(f"{what}: texture file not found: {named}")
        substitutions.append(f"{what}: texture file not found: {named}; rendered with the factor alone")
        return None
    if how is not None:       # a Windows path, another case, another folder: say which file was used
        (substitutions if substitutions is not None else warnings).append(
            f"{what}: texture {fname!r} not found as named; using {fpath} ({how})")
    kw = {}
    if "-s" in opts:
        s = [float(x) for x in opts["-s"][:2]] + [1.0] * (2 - len(opts["-s"][:2]))
        kw["scale"] = tuple(s)
    if "-o" in opts:
        o = [float(x) for x in opts["-o"][:2]] + [0.0] * (2 - len(opts["-o"][:2]))
        kw["offset"] = tuple(o)
    if normal and "-bm" in opts:        # a normal map's strength (Blender writes it so)
        kw["strength"] = float(opts["-bm"][0])
    ignored = set(opts) - {"-s", "-o"} - ({"-imfchan"} if alpha else set()) - ({"-bm"} if normal else set())
    if ignored:
        warnings.append(f"{what}: map options {sorted(ignored)} ignored")
    if alpha:
        return _mtl_scalar_map(fpath, what, opts.get("-imfchan"), kw)
    cache = {} if cache is None else cache
    key = (os.path.realpath(fpath), "linear" if normal or not srgb else "srgb")
    src = cache.get(key)
    try:
        if src is None:
            src = colour_texels(load_image(fpath, integers=True)[0])
            f = reduction_factor(src.shape, max_texture) if src.dtype != np.float32 else 1
            if f > 1:
                full = src.shape
                src = reduce_texels(src, f, 3 if srgb and not normal else 0)
                warnings.append(f"{what}: {fpath} {full[1]}x{full[0]} read at {src.shape[1]}x{src.shape[0]} (the "
                                f"texture budget, max_texture={max_texture}: its MIP level {f.bit_length() - 1})")
            kw["name"] = fpath
        t = NormalMap(src, **kw) if normal else ImageTexture(src, srgb=srgb, channels=3, **kw)
    except TextureError as exc:
        raise AssetError(f"{what}: {exc}") from None
    cache.setdefault(key, t)
    return t


#: ``-imfchan`` letters -> image channel (``m``, the "matte" channel, and the default: alpha if the image has one)
_IMFCHAN = {"r": 0, "g": 1, "b": 2}


def _mtl_scalar_map(fpath, what, imfchan, kw):
    """A 1-channel linear texture from an image (``map_d``): the channel ``-imfchan`` names (r, g, b), else the
    alpha channel of a grey+alpha / RGBA image, else its first channel (a grey matte)."""
    try:
        img = np.asarray(load_image(fpath)[0])
        c = img.shape[2] if img.ndim == 3 else 1
        img = img.reshape(img.shape[0], img.shape[1], c)
        want = str(imfchan[0]).lower() if imfchan else "m"
        if want in _IMFCHAN:
            if _IMFCHAN[want] >= c:
                raise AssetError(f"{what}: -imfchan {want} but the image has {c} channel(s)")
            k = _IMFCHAN[want]
        elif want in ("m", "l", "z"):
            k = c - 1 if c in (2, 4) else 0
        else:
            raise AssetError(f"{what}: -imfchan must be one of r, g, b, m, l, z, got {want!r}")
        return ImageTexture(np.ascontiguousarray(img[:, :, k]), srgb=False, name=f"{fpath} ({what.rsplit(': ', 1)[-1]})",
                            **kw)
    except TextureError as exc:
        raise AssetError(f"{what}: {exc}") from None


def parse_mtl(path, warnings=None, textures=None, substitutions=None, max_texture=None):
    """Parse an MTL file into {name: :class:`MTLParams`}; texture files are loaded (missing -> AssetError, or with
    a ``substitutions`` list a message there and the map left out).

    ``textures``: the per-load texel cache of :func:`_mtl_map` (a new one when None); each image file is
    decoded once per decoding however many maps name it.
    """
    warnings = warnings if warnings is not None else []
    textures = {} if textures is None else textures
    base = os.path.dirname(os.path.abspath(path))
    out, cur = {}, None
    mtl_map = functools.partial(_mtl_map, max_texture=max_texture)
    bumps = []          # (block, map_Bump arguments, where): normal maps or height maps, decided after the parse
    with open(path, "r", encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            tok = line.split()
            key, args = tok[0], tok[1:]
            where = f"{path}:{lineno}"
            if key == "newmtl":
                name = " ".join(args)
                cur = out[name] = MTLParams(name=name)
                continue
            if cur is None:   # (not echoing the token: a hostile OBJ may name any file as its MTL)
                raise AssetError(f"{where}: not an MTL file (a statement before any 'newmtl')")
            try:
                if key in ("Kd", "Ks", "Ke", "Tf"):
                    if args and args[0] in ("spectral", "xyz"):
                        warnings.append(f"{where}: {key} {args[0]} not supported; ignored")
                        continue
                    vals = [float(a) for a in args[:3]]
                    vals = vals * 3 if len(vals) == 1 else vals
                    if len(vals) != 3:
                        raise ValueError("need 1 or 3 numbers")
                    setattr(cur, key, np.asarray(vals, dtype=np.float64))
                elif key in ("Ns", "Ni"):
                    setattr(cur, key, float(args[0]))
                elif key == "d":
                    cur.d = float(args[-1])
                elif key == "Tr":
                    cur.d = 1.0 - float(args[0])
                elif key == "illum":
                    cur.illum = int(args[0])
                elif key == "map_Kd":
                    cur.map_Kd = mtl_map(args, base, f"{where}: map_Kd", srgb=True, warnings=warnings,
                                          cache=textures, substitutions=substitutions)
                elif key == "map_Ke":
                    cur.map_Ke = mtl_map(args, base, f"{where}: map_Ke", srgb=True, warnings=warnings,
                                          cache=textures, substitutions=substitutions)
                elif key == "map_d":
                    cur.map_d = mtl_map(args, base, f"{where}: map_d", srgb=False, warnings=warnings, alpha=True,
                                         cache=textures, substitutions=substitutions)
                elif key in ("norm", "map_Kn"):
                    cur.norm = mtl_map(args, base, f"{where}: {key}", srgb=False, warnings=warnings, normal=True,
                                        cache=textures, substitutions=substitutions)
                elif key in ("Pr", "Pm"):
                    setattr(cur, key, float(np.clip(float(args[0]), 0.0, 1.0)))
                elif key in ("map_Pr", "map_Pm"):
                    setattr(cur, key, mtl_map(args, base, f"{where}: {key}", srgb=False, warnings=warnings,
                                               alpha=True, cache=textures, substitutions=substitutions))
                elif key in ("bump", "map_Bump", "map_bump"):
                    bumps.append((cur, args, f"{where}: {key}"))
                elif key.startswith("map_") or key in ("disp", "decal", "refl"):
                    warnings.append(f"{where}: {key} not supported; ignored")
                elif key in ("Ka", "Ps", "Pc", "Pcr", "aniso", "anisor", "sharpness"):
                    pass  # not used by the mapping (see the module docstring)
                else:
                    shown = repr(key) if re.fullmatch(r"[A-Za-z_]\w{0,15}", key) else "(not shown)"
                    warnings.append(f"{where}: unknown MTL statement {shown} ignored")
            except AssetError:
                raise
            except (ValueError, IndexError) as exc:
                raise AssetError(f"{where}: cannot parse {line!r}: {exc}") from None
    for cur, args, where in bumps:
        _bump_map(cur, args, base, where, warnings, textures, substitutions, max_texture)
    return out


def looks_like_normal_map(texels):
    """True for an image whose mean colour is that of a tangent-space normal map (mostly +z: mean blue >= 0.6,
    mean red and green within 0.5 +- 0.15, as fractions of the code range); a grey height map is not."""
    a = np.asarray(texels)
    if a.ndim != 3 or a.shape[2] < 3:
        return False
    top = float(np.iinfo(a.dtype).max) if a.dtype.kind in "ui" else 1.0
    r, g, b = (float(a[:, :, c].mean()) / top for c in range(3))
    return b >= 0.6 and abs(r - 0.5) <= 0.15 and abs(g - 0.5) <= 0.15


def _bump_map(cur, args, base, where, warnings, textures, substitutions, max_texture=None):
    """``bump`` / ``map_Bump`` of MTL block ``cur``: its normal map when the image looks like one
    (:func:`looks_like_normal_map`) and ``norm`` gave none, else ignored (a height map), with a warning either way."""
    if cur.norm is not None:
        warnings.append(f"{where}: ignored (norm gives the material's normal map)")
        return
    t = _mtl_map(args, base, where, srgb=False, warnings=warnings, normal=True, cache=textures,
                 substitutions=substitutions, max_texture=max_texture)
    if t is None:
        return
    if looks_like_normal_map(t.texels[::4, ::4]):
        cur.norm = t
        warnings.append(f"{where}: {t.name} looks like a tangent-space normal map (as exporters write there): "
                        "used as the material's normal map")
    else:
        warnings.append(f"{where}: height (bump) maps are not supported; ignored")


def load_obj(path, max_texture=None):
    """Load an OBJ (+ MTL) file into an :class:`Asset` (MTL mapping: see the module docstring); colour and normal
    maps longer than ``max_texture`` texels are reduced as they are decoded (:mod:`pyrt.io.assets.texture_budget`)."""
    import trimesh  # deferred (pyrt.core.transforms)
    asset = Asset(path=path, format="obj")
    W = asset.warnings
    with open(path, "rb") as fh:
        raw = fh.read()
    try:  # trimesh decodes non-UTF-8 bytes with a charset detector that may not be installed: give it text
        text, utf8 = raw.decode("utf-8"), True
    except UnicodeDecodeError:
        text, utf8 = raw.decode("utf-8", errors="replace"), False
    has_vn = re.search(r"^\s*vn\s", text, flags=re.M) is not None
    mtls, textures = {}, {}  # textures: one decode per image file and decoding for the whole load
    base = os.path.dirname(os.path.abspath(path))
    subst, lib_missing = [], False
    for m in re.finditer(r"^\s*mtllib\s+(.+?)\s*$", text, flags=re.M):
        mpath, how = find_file(base, m.group(1))
        if mpath is None:      # trimesh reads the geometry without it: render with the default material
            subst.append(f"{path}: material library not found: {os.path.join(base, m.group(1).replace(chr(92), '/'))}"
                         "; the default material is used")
            lib_missing = True
            continue
        if how is not None:
            subst.append(f"{path}: material library {m.group(1)!r} not found as named; using {mpath} ({how})")
        mtls.update(parse_mtl(mpath, W, textures, substitutions=subst, max_texture=max_texture))
    used = set(re.findall(r"^\s*usemtl\s+(.+?)\s*$", text, flags=re.M))
    missing = used - set(mtls)
    if missing and not lib_missing:
        W.append(f"{path}: material(s) {sorted(missing)} not defined in the MTL; default material used")
    for msg in subst:
        asset.substitute(msg)
    tm = trimesh_load(path, "OBJ") if utf8 else trimesh_load(
        io.BytesIO(text.encode("utf-8")), "OBJ", file_type="obj", resolver=trimesh.resolvers.FilePathResolver(path),
        label=path)
    names = list(mtls)
    asset.materials = [mtls[n] for n in names]
    geoms = tm.geometry.items() if isinstance(tm, trimesh.Scene) else [("mesh", tm)]
    # trimesh groups OBJ faces by material; read each group's material name from the OBJ itself
    groups = _obj_material_groups(text)
    for gname, mesh in geoms:
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            continue
        mname = _trimesh_obj_material_name(mesh, gname, groups)
        mi = names.index(mname) if mname in names else -1
        uv = getattr(mesh.visual, "uv", None)
        uv = np.asarray(uv, dtype=np.float64) if uv is not None and len(uv) == len(mesh.vertices) else None
        colors = vertex_colors(mesh)
        normals = np.asarray(mesh.vertex_normals, dtype=np.float64) if has_vn else None
        asset.meshes.append(AssetMesh(name=str(gname), vertices=np.asarray(mesh.vertices, dtype=np.float64),
                                      faces=np.asarray(mesh.faces, dtype=np.int64), normals=normals, uv=uv,
                                      colors=colors, material=mi))
        asset.instances.append(AssetInstance(mesh=len(asset.meshes) - 1, world_from_object=np.eye(4),
                                             node=str(gname)))
    if not asset.instances:
        raise AssetError(f"{path}: no triangles found in the OBJ file (no 'f' statements with 3 or more vertices)")
    if not all(np.all(np.isfinite(m.vertices)) for m in asset.meshes):
        raise AssetError(f"{path}: {_first_nonfinite_vertex(text)} (NaN or Inf coordinates are not rendered)")
    for p in asset.materials:
        if mtl_is_transparent(p) and not (p.Ni is not None and p.Ni > 1.0):
            W.append(f"material {p.name!r}: transparent with Ni {p.Ni}; glass with ior 1.5 used")
        if not mtl_is_transparent(p) and not p.pbr:
            s = mtl_kd_ks(p)[2]
            if s < 1.0:
                W.append(f"material {p.name!r}: Kd + Ks > 1; Ks scaled by {s:.3f} to conserve energy")
    return asset


def _obj_material_groups(text):
    return re.findall(r"^\s*usemtl\s+(.+?)\s*$", text, flags=re.M)


def _trimesh_obj_material_name(mesh, gname, groups):
    mat = getattr(mesh.visual, "material", None)
    name = getattr(mat, "name", None)
    if name in groups:
        return name
    return gname if gname in groups else None


def _first_nonfinite_vertex(text):
    """Where the first ``v`` statement with a NaN or infinite coordinate is: "line 12: vertex 4 'v 0 nan 1'"."""
    k = 0
    for lineno, line in enumerate(text.splitlines(), 1):
        tok = line.split()
        if tok[:1] == ["v"]:
            k += 1
            try:
                finite = all(np.isfinite(float(t)) for t in tok[1:4])
            except ValueError:
                finite = False
            if not finite:
                return f"line {lineno}: vertex {k} {line.strip()[:60]!r} is not finite"
    return "a vertex position is not finite"
