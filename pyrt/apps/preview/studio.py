"""The previewer's procedural studio environment: soft boxes and a gradient, generated in code.

Metals and glossy surfaces reflect what is around them; under the key/fill/rim *directional* rig alone
there is nothing around them and a gold sphere renders black. :func:`studio_environment_image` is a small
lat-long map (256 x 128, float32, grey) of a photographic studio as seen from the model, in the frame of a
camera at azimuth 0 (on +z, looking toward -z): three soft boxes placed where the rig's key, fill and
rim lights are (:data:`pyrt.apps.preview.rig.RIG`, radiance proportional to each light's share of the key
irradiance), a dim wall gradient brighter toward the ceiling, and a darker floor. The previewer rotates
it with the camera azimuth, so reflections of the soft boxes sit where the rig's highlights are.

How it is used (:class:`pyrt.apps.preview.PreviewScene`): it *replaces* the constant ambient term. The
map is normalised to a mean radiance of 1 over the sphere and scaled to the ambient radiance
``ambient * key / pi``: a surface sees on average the light the ambient term gave it, only arriving from
the soft boxes rather than from everywhere (no double counting with the ambient; the directional
lights are unchanged). It is an :class:`~pyrt.lights.EnvironmentLight` with the ``"preview"`` strategy
(no shadow rays, no noise: SH irradiance for Lambertian hits, prefiltered lookups for the others) and
glossy reflection rays that escape the scene read the map itself; camera rays keep seeing the preview's
backdrop (``hide_background``).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from pyrt.shaders import envmap as _envmap
from pyrt.shaders import textures as _tex

from pyrt.lights.environment import PREFILTER_ALPHAS, LatLongEnvironment

#: (azimuth relative to the camera, elevation, half width, half height in degrees, radiance share) of the
#: soft boxes: where the rig's key, fill and rim lights are, with their shares of the key irradiance.
SOFT_BOXES = ((-40.0, 45.0, 22.0, 16.0, 1.0), (60.0, 15.0, 28.0, 20.0, 0.35), (160.0, 35.0, 9.0, 28.0, 0.7))

#: radiance of the walls (at the horizon and at the zenith) and of the floor, relative to a soft box of share 1
WALL_HORIZON, WALL_ZENITH, FLOOR = 0.06, 0.12, 0.03


def _soft_edge(t):
    """1 inside ``|t| <= 0.6``, 0 beyond 1, a smoothstep between: the soft box's falloff toward its edges."""
    s = np.clip((np.abs(t) - 0.6) / 0.4, 0.0, 1.0)
    return 1.0 - s * s * (3.0 - 2.0 * s)


def studio_environment_image(width=256, height=128):
    """The studio environment map, normalised to a mean radiance of 1 over the sphere.

    Parameters
    ----------
    width, height : int
        Map size in texels (lat-long, :mod:`pyrt.shaders.envmap`'s mapping: row 0 = +y).

    Returns
    -------
    (height, width, 3) float32 ndarray
        Grey radiance (R = G = B): the sum of the :data:`SOFT_BOXES` (each ``share`` inside a rectangle of
        the given angular half sizes around its centre, soft edges) and the walls (``WALL_HORIZON`` to
        ``WALL_ZENITH`` with ``sqrt(y)``) above the horizon, ``FLOOR`` below, divided by its solid-angle
        weighted mean, so ``sum L dOmega = 4 pi``.
    """
    d = _envmap.latlong_texel_directions(height, width)
    y = d[..., 1]
    L = np.where(y > 0, WALL_HORIZON + (WALL_ZENITH - WALL_HORIZON) * np.sqrt(np.clip(y, 0.0, 1.0)), FLOOR)
    for az, el, hw, hh, share in SOFT_BOXES:
        a, e = math.radians(az), math.radians(el)
        c = np.array([math.sin(a) * math.cos(e), math.sin(e), math.cos(a) * math.cos(e)])
        right = np.cross([0.0, 1.0, 0.0], c)
        right /= np.linalg.norm(right)
        up = np.cross(c, right)
        z = d @ c
        front = z > 0
        ang_u = np.degrees(np.arctan2(d @ right, np.where(front, z, 1.0)))
        ang_v = np.degrees(np.arctan2(d @ up, np.where(front, z, 1.0)))
        L = L + share * np.where(front, _soft_edge(ang_u / hw) * _soft_edge(ang_v / hh), 0.0)
    d_omega = _envmap.latlong_texel_solid_angle(height, width)[:, None]
    L = L / (float(np.sum(L * d_omega)) / (4.0 * math.pi))
    return np.repeat(L[..., None], 3, axis=2).astype(np.float32)


#: fixed BSDF samples per non-glossy, non-Lambertian hit of the ``"preview"`` estimate (the engine's default is 16;
#: 4 renders a textured model ~1.7x faster than 16, 1.6 % RMS from it: tools/experiments/bench_studio_env.py)
STUDIO_PREVIEW_SAMPLES = 4

#: Hammersley samples per texel of the studio's prefiltered maps (the engine's default for any map is 128)
PREFILTER_SAMPLES = 64


class StudioEnvironment(LatLongEnvironment):
    """:func:`studio_environment_image` as a :class:`~pyrt.lights.LatLongEnvironment`, with a cheaper prefilter.

    The map is grey and smooth, so its GGX-prefiltered stack (read by the ``"preview"`` strategy at every
    non-glossy, non-Lambertian hit) is built on one channel, at half the map's width at most, with
    :data:`PREFILTER_SAMPLES` filtered-importance samples per texel instead of the engine's 128 on three
    channels at full width: about 5x faster (0.7 s against 3.8 s here, under load), within 3 % of the map's
    maximum of the engine's stack at every width (tests/test_preview_studio.py).
    """

    #: the kernel reads it as any lat-long map (:func:`pyrt.lights.compiled_env.packable`): only the prefiltered
    #: stack's build differs, and the compiled preview packs the stack this class builds
    compiled_kind = "latlong"

    def __init__(self, *, width=256, height=128, intensity=1.0, name="studio"):
        super().__init__(studio_environment_image(width, height), intensity=intensity, name=name)

    def _build_prefiltered(self):
        grey = np.asarray(self.image[..., :1], dtype=np.float64)
        one = shipped_prefiltered(grey)
        if one is None:
            one = build_studio_prefiltered(grey)
        return [np.asarray(self.image, dtype=np.float64)] + [np.repeat(m, 3, axis=2) for m in one]


def build_studio_prefiltered(grey):
    """The studio stack's prefiltered maps (one channel, float64) for ``PREFILTER_ALPHAS[1:]`` from the grey map
    ``grey`` (H, W, 1): at half the map's width at most, :data:`PREFILTER_SAMPLES` samples per texel."""
    h, w = grey.shape[:2]
    levels = [_tex.build_mip_level(grey, lv) for lv in range(_tex.n_mip_levels(grey.shape))]
    maps = []
    for a in PREFILTER_ALPHAS[1:]:
        wo = int(min(w // 2, max(32, 2 ** math.ceil(math.log2(4.0 * math.pi / a)))))
        maps.append(_envmap.prefilter_latlong_ggx(levels, a, (max(16, wo // 2), wo), n_samples=PREFILTER_SAMPLES))
    return maps


#: :func:`build_studio_prefiltered` of the default 256 x 128 map in float32 (within 6e-8 of the float64 build),
#: shipped with pyrt (``tools/make_tables.py`` writes it; tests/test_preview_studio.py checks it against a fresh
#: build): reading it takes ~2 ms, building it ~0.2 s of every preview process
PREFILTERED_FILE = Path(__file__).with_name("studio_prefiltered.npz")


def image_fingerprint(grey):
    """Three sums of the map (float64) that any change of the studio's definition changes (not bit-exact: the
    map's transcendental functions may differ in the last bit between CPUs; compared with rtol 1e-9)."""
    g = np.asarray(grey, dtype=np.float64).ravel()
    return np.array([g.sum(), (g * g).sum(), (g * np.linspace(0.0, 1.0, g.size)).sum()])


def shipped_prefiltered(grey):
    """The maps of :data:`PREFILTERED_FILE` when they were built from this ``grey`` map with today's alphas and
    sample count (else None: the caller builds them)."""
    try:
        with np.load(PREFILTERED_FILE) as f:
            ok = (f["shape"].tolist() == list(grey.shape) and f["alphas"].tolist() == list(PREFILTER_ALPHAS)
                  and int(f["samples"]) == PREFILTER_SAMPLES
                  and np.allclose(f["fingerprint"], image_fingerprint(grey), rtol=1e-9, atol=0.0))
            return [f[f"map{k}"].astype(np.float64) for k in range(len(PREFILTER_ALPHAS) - 1)] if ok else None
    except (OSError, KeyError, ValueError):
        return None


def write_shipped_prefiltered(path=PREFILTERED_FILE):
    """Build the default studio map's stack and write it to ``path`` (what ``tools/make_tables.py`` runs)."""
    grey = studio_environment_image(256, 128)[..., :1].astype(np.float64)
    maps = build_studio_prefiltered(grey)
    np.savez_compressed(path, shape=np.array(grey.shape), alphas=np.array(PREFILTER_ALPHAS),
                        samples=np.array(PREFILTER_SAMPLES), fingerprint=image_fingerprint(grey),
                        **{f"map{k}": m.astype(np.float32) for k, m in enumerate(maps)})
    return path


def camera_rotation(azimuth):
    """3x3 ``world_from_env`` rotation about +y by ``azimuth`` degrees: the studio turns with the camera."""
    a = math.radians(azimuth)
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
