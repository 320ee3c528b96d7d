"""Render check: a GGX conductor sphere under a point light matches the closed-form BRDF.

Each lit pixel's radiance must equal f(wo, wi) cos(theta_i) I / r^2 with f the Cook-Torrance
GGX BRDF (height-correlated Smith G, exact conductor Fresnel for gold), evaluated here from a
separate scalar implementation of the formulas (Python ``math``/``cmath``), at the hit point and
shading normal the renderer reports (depth and normal AOVs of pixel-centre rays).
"""
import cmath
import math

import numpy as np
import pytest

import pyrt
from pyrt.materials import CookTorrance
from pyrt.shaders import metals

ALPHA = 0.25  # roughness 0.5
I_LIGHT = 12.0
LIGHT = np.array([2.0, 2.5, 3.0])


def fresnel_conductor(cos_i, eta, k):
    n = complex(eta, k)
    sin2 = 1.0 - cos_i * cos_i
    cos_t = cmath.sqrt(1.0 - sin2 / (n * n))
    rs = (cos_i - n * cos_t) / (cos_i + n * cos_t)
    rp = (n * cos_i - cos_t) / (n * cos_i + cos_t)
    return 0.5 * (abs(rs) ** 2 + abs(rp) ** 2)


def ggx_brdf(n, wo, wi, eta, k):
    h = wo + wi
    h = h / np.linalg.norm(h)
    cn_o, cn_i, cn_h, c_oh = float(n @ wo), float(n @ wi), float(n @ h), float(wo @ h)
    a2 = ALPHA * ALPHA
    D = a2 / (math.pi * (cn_h * cn_h * (a2 - 1.0) + 1.0) ** 2)

    def lam(c):
        return (math.sqrt(1.0 + a2 * (1.0 - c * c) / (c * c)) - 1.0) / 2.0

    G = 1.0 / (1.0 + lam(cn_o) + lam(cn_i))
    F = np.array([fresnel_conductor(c_oh, eta[c], k[c]) for c in range(3)])
    return F * D * G / (4.0 * cn_o * cn_i)


@pytest.fixture(scope="module")
def rendered():
    cam = pyrt.Camera(position=(0, 0, 4), target=(0, 0, 0), up=(0, 1, 0), fov=32, width=48, height=48,
                      spp=1, jitter=False)
    scene = pyrt.Scene(cam)
    scene.add_sphere((0, 0, 0), 1.0, CookTorrance(metal="gold", roughness=0.5), subdivisions=5)
    scene.add_light(pyrt.PointLight(LIGHT, intensity=I_LIGHT))
    res = pyrt.render_full(scene, aovs=True)
    return cam, res


def test_ggx_gold_sphere_matches_closed_form(rendered):
    cam, res = rendered
    img, depth, normal = res.image, res.aovs["depth"], res.aovs["normal"]
    eta, k = metals.METALS["gold"]
    ys, xs = np.mgrid[0:cam.height, 0:cam.width]
    d = cam.directions(xs.ravel() + 0.5, ys.ravel() + 0.5).reshape(cam.height, cam.width, 3)
    checked, worst = 0, 0.0
    for y in range(0, cam.height, 3):
        for x in range(0, cam.width, 3):
            if not np.isfinite(depth[y, x]) or depth[y, x] <= 0:
                continue
            p = cam.position + float(depth[y, x]) * d[y, x]
            n = normal[y, x].astype(np.float64)
            n /= np.linalg.norm(n)
            wo = -d[y, x]
            to_l = LIGHT - p
            r2 = float(to_l @ to_l)
            wi = to_l / math.sqrt(r2)
            if n @ wi < 0.3 or n @ wo < 0.3:  # away from the terminator and the silhouette
                continue
            expect = ggx_brdf(n, wo, wi, eta, k) * float(n @ wi) * I_LIGHT / r2
            rel = np.max(np.abs(img[y, x] - expect) / expect)
            worst = max(worst, rel)
            checked += 1
    assert checked >= 40
    # float32 image and AOVs (depth, normal) bound the agreement: measured 3.5e-7 relative over
    # 88 pixels; separable instead of height-correlated Smith would be off by 4e-3
    assert worst < 2e-5, worst


def test_highlight_is_where_the_half_vector_meets_the_normal(rendered):
    cam, res = rendered
    lum = res.image.sum(-1)
    y, x = np.unravel_index(np.argmax(lum), lum.shape)
    n = res.aovs["normal"][y, x].astype(np.float64)
    d = cam.directions(np.array([x + 0.5]), np.array([y + 0.5]))[0]
    p = cam.position + float(res.aovs["depth"][y, x]) * d
    wi = (LIGHT - p) / np.linalg.norm(LIGHT - p)
    h = (wi - d) / np.linalg.norm(wi - d)
    assert n @ h / np.linalg.norm(n) > 0.995  # within ~6 degrees (pixel size and 1/r^2, cos falloff)
