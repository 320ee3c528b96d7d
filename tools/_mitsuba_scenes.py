"""The scenes of tools/bench_mitsuba.py, built once in pyrt and translated to Mitsuba 3 with matched conventions.

Every scene is built as a :class:`pyrt.Scene` (the single source of truth); :func:`mitsuba_dict` reads its
meshes (world-space float32 vertices, vertex normals, UVs as pyrt prepared them: the *same* triangles, written
to PLY files), materials, lights, camera and environment and writes the Mitsuba 3 scene dict. Only the types
listed in :data:`SUPPORTED` translate; anything else is a ``pyrt.Error`` naming the object (so a new scene
cannot silently diverge).

The conventions matched (tools/bench_mitsuba.py's docstring is the full table):

- camera: pinhole, *vertical* fov (Mitsuba ``fov_axis="y"``), look-at with the same up; pixel (row, col) covers
  [col, col+1) x [row, row+1), samples uniform within it; Mitsuba ``box`` rfilter (radius 0.5 = the pixel).
- point light: pyrt ``intensity`` I (W/sr) x ``color`` = Mitsuba ``point`` ``intensity``; spot: pyrt
  ``spot_falloff="linear_angle"`` = Mitsuba ``spot`` (linear in angle from ``beam_width`` = inner angle to
  ``cutoff_angle`` = outer angle); directional: pyrt irradiance E (W/m^2) = Mitsuba ``irradiance``,
  ``direction`` is where the light travels in both.
- Lambert albedo = ``diffuse`` reflectance; Mirror = ``conductor`` with ``material="none"`` (F = 1) times
  ``specular_reflectance``; Glass = ``dielectric`` (exact Fresnel, radiance 1/eta^2 on refraction in both);
  CookTorrance(GGX, conductor Fresnel, eta/k RGB) = ``roughconductor`` with ``alpha`` = roughness^2 (pyrt's
  mapping, see CookTorrance's docstring) and the *separable* Smith G (what Mitsuba uses; the bench builds
  pyrt's sphere with ``geometry="smith_separable"``).
- textures: pyrt uv (0, 0) = bottom-left, Mitsuba's bitmap puts v = 0 at the top row: the PLY files carry
  ``v' = 1 - v`` (:func:`mitsuba_uv`); the checkerboard is the pyrt ``CheckerTexture(filtered=False)`` (Mitsuba's
  is point-sampled, 2 cells per uv unit: ``to_uv`` scale = scale / 2, :func:`mitsuba_checker_scale`); image
  textures bilinear, no MIP (pyrt ``filter="bilinear"``).
- environment: pyrt's lat-long direction mapping is Mitsuba's ``envmap`` (u = atan2(x, -z)/2pi, v = acos(y)/pi,
  row 0 = +y) but Mitsuba's rows sit at v = j/(H-1) (pyrt's at (j + 1/2)/H): Mitsuba reads
  :func:`mitsuba_envmap_image` of pyrt's map (2H + 1 rows, the same bilinear radiance); one-hot renders in
  tests/test_bench_mitsuba.py check the orientation.
"""
from __future__ import annotations

import os

import numpy as np

import pyrt

#: pyrt types :func:`mitsuba_dict` translates
SUPPORTED = ("Lambert (constant, CheckerTexture(filtered=False), ImageTexture(file))", "Mirror", "Glass",
             "CookTorrance(distribution='ggx', fresnel='conductor', geometry='smith_separable')",
             "PointLight", "SpotLight(spot_falloff='linear_angle')", "DirectionalLight",
             "LatLongEnvironment(file) via EnvironmentLight('mis')")

WIDTH, HEIGHT = 320, 240
#: pyrt render options every bench render uses (Mitsuba has no terminator lift and no shading-normal
#: fallback; throughput_cutoff 0: Mitsuba's Whitted below traces every bounce to max_depth)
PYRT_OPTIONS = {"integrator": pyrt.Whitted(max_depth=8, offset="robust_no_terminator", throughput_cutoff=0.0)}


class BenchSceneError(pyrt.Error):
    """A bench scene uses something the Mitsuba translation cannot express."""


# ----------------------------------------------------------------------------- convention helpers

def mitsuba_uv(uv):
    """pyrt uv (v up, (0, 0) = bottom-left of the image) -> Mitsuba bitmap uv (v = 0 at the top row)."""
    uv = np.asarray(uv, dtype=np.float64)
    return np.column_stack([uv[:, 0], 1.0 - uv[:, 1]])


def mitsuba_checker_scale(scale):
    """pyrt checker ``scale`` (cells per uv unit, a number or (su, sv)) -> Mitsuba ``checkerboard`` ``to_uv``
    scale [su / 2, sv / 2] (it draws 2 cells per uv unit, colour0 where both fractional parts are on the same
    side of 1/2: pyrt's even cells)."""
    su, sv = np.broadcast_to(np.asarray(scale, dtype=np.float64), (2,))
    return [float(su) / 2.0, float(sv) / 2.0]


def mitsuba_checker_colors(scale, color0, color1):
    """Mitsuba ``checkerboard`` (color0, color1) for pyrt's ``CheckerTexture(color0, color1, scale)`` on uvs
    flipped by :func:`mitsuba_uv`: ``floor(s (1 - v)) = s - 1 - floor(s v)`` changes the cell parity when the
    integer v scale s is even, so the colours swap then."""
    sv = float(np.broadcast_to(np.asarray(scale, dtype=np.float64), (2,))[1])
    if sv != int(sv):
        raise BenchSceneError(f"checker scale {scale!r}: only an integer v scale keeps the cells of a flipped v")
    return (color1, color0) if int(sv) % 2 == 0 else (color0, color1)


def alpha_from_roughness(roughness):
    """GGX alpha for Mitsuba's ``roughconductor`` from pyrt's perceptual roughness: alpha = r^2."""
    return float(roughness) ** 2


def latlong_texel_direction(row, col, height, width):
    """World direction of the centre of lat-long texel (row, col): pyrt's (and Mitsuba's envmap) mapping
    u = atan2(x, -z) / 2pi, v = acos(y) / pi, row 0 = +y, texel centres at half-integers."""
    u = (col + 0.5) / width
    v = (row + 0.5) / height
    phi, theta = 2.0 * np.pi * u, np.pi * v
    return np.array([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)])


def mitsuba_envmap_image(image):
    """The lat-long image to give Mitsuba's ``envmap`` so that it returns pyrt's bilinear radiance exactly.

    pyrt puts texel centres at v = (j + 1/2) / H and clamps at the poles; Mitsuba's envmap (src/emitters/
    envmap.cpp, ``eval_spectrum``) puts row j at v = j / (H' - 1), pole rows included (in u both use half-texel
    centres and wrap). Both interpolate linearly between their rows, so a map of H' = 2H + 1 rows at
    v = k / 2H -- pyrt's rows at odd k, midpoints of neighbouring rows at even k, the pole rows repeated at
    k = 0 and 2H -- has pyrt's knots among Mitsuba's and reproduces pyrt's lookup (tests check it against a
    NumPy transcription of Mitsuba's lookup).
    """
    img = np.asarray(image, dtype=np.float32)
    h = img.shape[0]
    out = np.empty((2 * h + 1,) + img.shape[1:], dtype=np.float32)
    out[0], out[-1] = img[0], img[-1]
    out[1::2] = img
    out[2:-1:2] = 0.5 * (img[:-1] + img[1:])
    return out


def one_hot_latlong(height, width, row, col, value=100.0):
    """A black (height, width, 3) float32 lat-long map with one bright texel (orientation checks)."""
    img = np.zeros((height, width, 3), dtype=np.float32)
    img[row, col] = value
    return img


# ----------------------------------------------------------------------------- pyrt scenes

def _camera(position, target, fov, spp=1):
    return pyrt.Camera(position=position, target=target, up=(0, 1, 0), fov=fov, width=WIDTH, height=HEIGHT, spp=spp)


def scene_diffuse(workdir=None):
    """Diffuse sphere on a diffuse ground, one point light."""
    s = pyrt.Scene(_camera((0, 1.0, 4.0), (0, 0.5, 0), 40), shading_normal_fallback=False)
    s.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=0.7), name="ground")
    s.add_sphere((0, 0.5, 0), 0.5, pyrt.Lambert(albedo=(0.7, 0.2, 0.2)), subdivisions=5, name="sphere")
    s.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    return s


def scene_shadowed(workdir=None):
    """Diffuse ground mostly in the shadow of a floating slab, one point light."""
    s = pyrt.Scene(_camera((0, 3.0, 3.5), (0, 0, 0), 45), shading_normal_fallback=False)
    s.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=0.7), name="ground")
    s.add_box((0.0, 1.2, 0.0), (1.6, 0.1, 1.2), pyrt.Lambert(albedo=0.5), name="slab")
    s.add_light(pyrt.PointLight((0.4, 3.0, 0.3), intensity=15.0))
    return s


def scene_mirror_glass(workdir=None):
    """Mirror and glass spheres over a checker ground, one point light, a constant background."""
    s = pyrt.Scene(_camera((0, 1.2, 4.0), (0, 0.5, 0), 40), background=(0.05, 0.06, 0.1),
                   shading_normal_fallback=False)
    s.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.15, 0.8, scale=8, filtered=False)),
                name="ground")
    s.add_sphere((-0.6, 0.5, -0.2), 0.5, pyrt.Mirror(0.9), subdivisions=5, name="mirror")
    s.add_sphere((0.6, 0.5, 0.3), 0.5, pyrt.Glass(ior=1.5), subdivisions=5, name="glass")
    s.add_light(pyrt.PointLight((2, 4, 3), intensity=30.0))
    return s


def ground_texture(size=256):
    """A linear-RGB (size, size, 3) float32 pattern for the sky scene's ground: tiles of varying colour with
    a smooth stripe, asymmetric in u and v (so a flipped axis shows)."""
    y, x = np.mgrid[0:size, 0:size] / size
    tiles = ((np.floor(x * 8) + 2 * np.floor(y * 8)) % 5) / 4.0
    img = np.stack([0.15 + 0.6 * tiles, 0.2 + 0.4 * x, 0.1 + 0.5 * (1 - y) * (0.5 + 0.5 * np.sin(12 * x))], axis=-1)
    return img.astype(np.float32)


def scene_sky(workdir):
    """Textured ground and a rough gold sphere under an HDR sky with a sun (both maps written to ``workdir``)."""
    workdir = os.fspath(workdir)
    os.makedirs(workdir, exist_ok=True)
    sky_path, tex_path = os.path.join(workdir, "sky.exr"), os.path.join(workdir, "ground.exr")
    sky = pyrt.procedural_sky(512, 256, sun_direction=(0.5, 0.6, 0.4), sun_angle=3.0,
                              sun_radiance=(400.0, 360.0, 300.0))
    pyrt.write_exr(sky_path, sky)
    mi_sky_path = os.path.join(workdir, "sky_mitsuba.exr")
    pyrt.write_exr(mi_sky_path, mitsuba_envmap_image(sky))
    pyrt.write_exr(tex_path, ground_texture())
    s = pyrt.Scene(_camera((0, 1.0, 3.6), (0, 0.45, 0), 40), shading_normal_fallback=False)
    tex = pyrt.ImageTexture(tex_path, filter="bilinear", scale=(2.0, 2.0))
    s.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=tex), name="ground")
    s.add_sphere((0, 0.6, 0), 0.6, pyrt.CookTorrance(metal="gold", roughness=0.5, geometry="smith_separable"),
                 subdivisions=5, name="gold")
    env = pyrt.LatLongEnvironment(sky_path)
    env.bench_path = mi_sky_path    # the file Mitsuba's envmap reads (mitsuba_envmap_image)
    pyrt.set_environment(s, env, lighting="mis")
    return s


DEFAULT_SCENE = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "assets", "default_scene.toml")

#: what the default scene loses in translation (the bench renders this variant in *both* renderers)
DEFAULT_SCENE_CHANGES = ("the Blinn-Phong cylinder becomes Lambert(kd) (Mitsuba 3 has no Blinn-Phong BSDF)",
                         "the spot light's falloff is linear in angle (Mitsuba's spot) instead of smoothstep",
                         "320x240 instead of 640x480")


def scene_default(workdir=None):
    """``assets/default_scene.toml`` with :data:`DEFAULT_SCENE_CHANGES` applied."""
    scene, _opts = pyrt.load_scene(DEFAULT_SCENE)
    for i, m in enumerate(scene.materials):
        if isinstance(m, pyrt.BlinnPhong):
            scene.materials[i] = pyrt.Lambert(albedo=m.kd, name=m.name)
    for lt in scene.lights:
        if isinstance(lt, pyrt.SpotLight):
            lt.spot_falloff = "linear_angle"
    cam = scene.camera
    scene.camera = _camera(cam.position, cam.target, cam.fov)
    scene.shading_normal_fallback = False
    return scene


#: name -> (builder, description, Mitsuba integrator kind)
SCENES = {
    "diffuse": (scene_diffuse, "diffuse sphere + ground, one point light", "direct"),
    "shadowed": (scene_shadowed, "diffuse ground, shadowed, one point light", "direct"),
    "mirror_glass": (scene_mirror_glass, "mirror + glass spheres over a checker ground", "whitted"),
    "sky": (scene_sky, "textured ground + rough metal sphere, HDR sky with a sun", "direct"),
    "default": (scene_default, "assets/default_scene.toml (Blinn-Phong -> Lambert, linear spot)", "whitted"),
}


# ----------------------------------------------------------------------------- translation to Mitsuba

def write_ply(path, vertices, faces, normals=None, uv=None):
    """A binary little-endian PLY: float32 x y z [nx ny nz] [u v] per vertex, uchar/int triangle lists."""
    v = np.asarray(vertices, dtype=np.float32)
    cols, props = [v], ["x", "y", "z"]
    if normals is not None:
        cols.append(np.asarray(normals, dtype=np.float32))
        props += ["nx", "ny", "nz"]
    if uv is not None:
        cols.append(np.asarray(uv, dtype=np.float32))
        props += ["u", "v"]
    vert = np.ascontiguousarray(np.concatenate(cols, axis=1), dtype="<f4")
    f = np.asarray(faces, dtype="<i4")
    face = np.empty(f.shape[0], dtype=[("n", "u1"), ("i", "<i4", (3,))])
    face["n"], face["i"] = 3, f
    head = ["ply", "format binary_little_endian 1.0", f"element vertex {v.shape[0]}"]
    head += [f"property float {p}" for p in props]
    head += [f"element face {f.shape[0]}", "property list uchar int vertex_indices", "end_header"]
    with open(path, "wb") as fh:
        fh.write(("\n".join(head) + "\n").encode("ascii"))
        fh.write(vert.tobytes())
        fh.write(face.tobytes())
    return path


def _rgb(v):
    a = np.broadcast_to(np.asarray(v, dtype=np.float64), (3,))
    return {"type": "rgb", "value": [float(x) for x in a]}


def _uv_scale(mi, s):
    return mi.ScalarTransform4f().scale([float(s[0]), float(s[1]), 1.0])


def _albedo(mi, tex, who):
    if isinstance(tex, pyrt.CheckerTexture):
        if tex.filtered or tex.space != "uv":
            raise BenchSceneError(f"{who}: only CheckerTexture(filtered=False, space='uv') translates")
        c0, c1 = mitsuba_checker_colors(tex.scale, tex.color0, tex.color1)
        return {"type": "checkerboard", "color0": _rgb(c0), "color1": _rgb(c1),
                "to_uv": _uv_scale(mi, mitsuba_checker_scale(tex.scale))}
    if isinstance(tex, pyrt.ImageTexture):
        if not tex.path or tex.filter != "bilinear":
            raise BenchSceneError(f"{who}: only file ImageTextures with filter='bilinear' translate")
        return {"type": "bitmap", "filename": os.fspath(tex.path), "filter_type": "bilinear", "raw": True,
                "to_uv": _uv_scale(mi, tex.scale)}
    if isinstance(tex, pyrt.Texture):
        raise BenchSceneError(f"{who}: texture {type(tex).__name__} does not translate")
    return _rgb(tex)


def mitsuba_bsdf(mi, mat):
    """The Mitsuba 3 BSDF dict of a pyrt material (see the module docstring); ``BenchSceneError`` otherwise."""
    who = f"{type(mat).__name__}({mat.name or ''})"
    if isinstance(mat, pyrt.Lambert):
        return {"type": "diffuse", "reflectance": _albedo(mi, mat.albedo_value, who)}
    if isinstance(mat, pyrt.Mirror):
        return {"type": "conductor", "material": "none", "specular_reflectance": _rgb(mat.reflectance)}
    if isinstance(mat, pyrt.Glass):
        if np.any(np.asarray(mat.tint) != 1) or np.any(np.asarray(mat.absorption) != 0):
            raise BenchSceneError(f"{who}: tinted or absorbing glass does not translate")
        return {"type": "dielectric", "int_ior": float(mat.ior), "ext_ior": 1.0}
    if isinstance(mat, pyrt.CookTorrance):
        ok = (mat.distribution == "ggx" and mat.fresnel == "conductor" and mat.geometry == "smith_separable"
              and mat.rough_kind == "roughness" and np.all(np.asarray(mat.kd) == 0) and np.all(np.asarray(mat.ks) == 1))
        if not ok:
            raise BenchSceneError(f"{who}: only GGX conductors with kd=0, ks=1, separable Smith and a roughness translate")
        return {"type": "roughconductor", "distribution": "ggx", "alpha": alpha_from_roughness(mat.rough),
                "eta": _rgb(mat.eta), "k": _rgb(mat.k), "sample_visible": True}
    raise BenchSceneError(f"{who}: material type does not translate to Mitsuba 3 (supported: {SUPPORTED})")


def _look_at(mi, origin, target, up):
    return mi.ScalarTransform4f().look_at(origin=[float(x) for x in origin], target=[float(x) for x in target],
                                          up=[float(x) for x in up])


def mitsuba_emitter(mi, light):
    """The Mitsuba 3 emitter dict of a pyrt light, or None for the environment light (handled by the scene)."""
    who = f"{type(light).__name__}({light.name or ''})"
    if isinstance(light, pyrt.EnvironmentLight):
        return None
    if type(light) is pyrt.PointLight and light.falloff == "inverse_square":
        return {"type": "point", "position": [float(x) for x in light.position],
                "intensity": _rgb(light.intensity * np.asarray(light.color))}
    if type(light) is pyrt.SpotLight and light.falloff == "inverse_square":
        if light.spot_falloff != "linear_angle":
            raise BenchSceneError(f"{who}: only spot_falloff='linear_angle' (Mitsuba's spot) translates")
        up = (0, 1, 0) if abs(light.direction[1]) < 0.99 else (1, 0, 0)
        return {"type": "spot", "to_world": _look_at(mi, light.position, light.position + light.direction, up),
                "cutoff_angle": float(light.outer_angle), "beam_width": float(light.inner_angle),
                "intensity": _rgb(light.intensity * np.asarray(light.color))}
    if type(light) is pyrt.DirectionalLight:
        return {"type": "directional", "direction": [float(x) for x in light.direction],
                "irradiance": _rgb(light.irradiance * np.asarray(light.color))}
    raise BenchSceneError(f"{who}: light type does not translate to Mitsuba 3 (supported: {SUPPORTED})")


def mitsuba_dict(mi, scene, workdir, *, integrator, spp=16, sampler="independent", max_depth=8):
    """The Mitsuba 3 scene dict of a pyrt scene (meshes written as PLY files to ``workdir``).

    ``integrator``: ``"direct"`` (Mitsuba's, one emitter sample; one BSDF sample only with an environment, as
    pyrt's ``mis`` strategy) or ``"whitted"`` (:func:`register_whitted`, which must have been called).
    """
    os.makedirs(workdir, exist_ok=True)
    cam = scene.camera
    d = {"type": "scene",
         "sensor": {"type": "perspective", "fov_axis": "y", "fov": float(cam.fov),
                    "to_world": _look_at(mi, cam.position, cam.target, cam.up),
                    "film": {"type": "hdrfilm", "width": cam.width, "height": cam.height,
                             "rfilter": {"type": "box"}, "pixel_format": "rgb", "component_format": "float32"},
                    "sampler": {"type": sampler, "sample_count": int(spp)}}}
    env = scene.environment
    if integrator == "direct":
        d["integrator"] = {"type": "direct", "emitter_samples": 1, "bsdf_samples": 1 if env is not None else 0}
    else:
        d["integrator"] = {"type": "whitted_bench", "max_depth": int(max_depth),
                           **{f"background_{c}": float(x) for c, x in zip("rgb", scene.background)}}
    for i, m in enumerate(scene.meshes):
        path = write_ply(os.path.join(workdir, f"mesh{i}.ply"), m.vertices, m.faces, m.normals,
                         None if m.uv is None else mitsuba_uv(m.uv))
        shape = {"type": "ply", "filename": path, "bsdf": mitsuba_bsdf(mi, scene.materials[m.material_id])}
        if m.normals is None:
            shape["face_normals"] = True
        d[f"mesh{i}"] = shape
    for i, lt in enumerate(scene.lights):
        em = mitsuba_emitter(mi, lt)
        if em is not None:
            d[f"light{i}"] = em
    if env is not None:
        if not isinstance(env, pyrt.LatLongEnvironment) or not env_path(env):
            raise BenchSceneError("environment: only a LatLongEnvironment read from a file translates")
        d["environment"] = {"type": "envmap", "filename": env_path(env), "scale": float(env.intensity)}
    return d


def env_path(env):
    """The EXR file Mitsuba reads for a bench environment (:func:`mitsuba_envmap_image` of pyrt's map; the
    bench builders keep its path on ``env.bench_path``)."""
    return env.bench_path


# ----------------------------------------------------------------------------- Whitted in Mitsuba

def register_whitted(mi, dr):
    """Register ``whitted_bench``, pyrt's Whitted estimator as a ``mi.SamplingIntegrator`` (current variant).

    Per path vertex: where the BSDF has a smooth (non-delta) lobe, one sample and one shadow ray per emitter
    (every light at every hit, as pyrt; Mitsuba's ``sample_emitter_direction`` would pick one light with
    pdf 1/n: same expectation, up to n times the variance) and the path ends; at a delta BSDF (mirror, glass) the path
    continues along a BSDF sample (Mitsuba's dielectric *chooses* reflection or refraction with probability
    R, pyrt splits both deterministically: same expectation). Misses add ``background`` at any depth;
    ``max_depth`` counts specular bounces as pyrt's (camera ray + ``max_depth`` bounces). The loop is a
    Python loop unrolled ``max_depth + 1`` times, which ``llvm_ad_rgb`` traces into one kernel.
    """

    class WhittedBench(mi.SamplingIntegrator):
        """pyrt's Whitted estimator (see :func:`register_whitted`)."""

        def __init__(self, props):
            super().__init__(props)
            self.max_depth = props.get("max_depth", 8)
            bg = [props.get(f"background_{c}", 0.0) for c in "rgb"]
            self.background = mi.Color3f(*(float(x) for x in bg))

        def sample(self, scene, sampler, ray, medium=None, active=True):
            """One camera sample: (radiance, valid, aovs)."""
            ctx = mi.BSDFContext()
            ray = mi.Ray3f(ray)
            emitters = scene.emitters()
            scalar = not dr.is_jit_v(mi.Float)
            neg = (lambda m: not m) if scalar else (lambda m: ~m)    # ~True is -2 on scalar_rgb's Python bools
            L = mi.Color3f(0.0)
            thr = mi.Color3f(1.0)
            active = mi.Bool(active)
            for depth in range(self.max_depth + 1):
                si = scene.ray_intersect(ray, active)
                miss = active & neg(si.is_valid())
                L += dr.select(miss, thr * self.background, mi.Color3f(0.0))
                active &= si.is_valid()
                if scalar and not active:     # scalar_rgb: one lane, no BSDF to ask on a miss
                    break
                bsdf = si.bsdf(ray)
                smooth = active & mi.has_flag(bsdf.flags(), mi.BSDFFlags.Smooth)
                for em in emitters:      # every light at every hit, one shadow ray each (as pyrt)
                    ds, em_w = em.sample_direction(si, sampler.next_2d(smooth), smooth)
                    lit = smooth & (ds.pdf > 0)
                    lit &= neg(scene.ray_test(si.spawn_ray_to(ds.p), lit))
                    f = bsdf.eval(ctx, si, si.to_local(ds.d), lit)
                    L += dr.select(lit, thr * f * em_w, mi.Color3f(0.0))
                active &= neg(smooth)
                if depth == self.max_depth:
                    break
                bs, w = bsdf.sample(ctx, si, sampler.next_1d(active), sampler.next_2d(active), active)
                thr *= dr.select(active, w, mi.Color3f(0.0))
                active &= dr.any(thr != 0)
                ray = si.spawn_ray(si.to_world(bs.wo))
            return L, mi.Bool(True), []

        def aov_names(self):
            """No AOVs."""
            return []

        def to_string(self):
            """The plugin's name."""
            return f"WhittedBench[max_depth={self.max_depth}]"

    mi.register_integrator("whitted_bench", lambda props: WhittedBench(props))


def ply_header(path):
    """The ASCII header lines of a PLY file (for tests)."""
    with open(path, "rb") as fh:
        data = fh.read(4096)
    head = data[:data.index(b"end_header")].decode("ascii")
    return head.splitlines()


def ply_body(path, n_vertices, n_props):
    """The vertex block of a PLY written by :func:`write_ply` as (n_vertices, n_props) float32 (for tests)."""
    with open(path, "rb") as fh:
        data = fh.read()
    start = data.index(b"end_header\n") + len(b"end_header\n")
    return np.frombuffer(data[start:start + 4 * n_vertices * n_props], dtype="<f4").reshape(n_vertices, n_props)

