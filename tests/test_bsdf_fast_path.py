"""The isotropic fast path (IsotropicMaterial.f_cos_cosines, world-space cosines) equals the local-frame f_cos."""
import numpy as np
import pytest

import pyrt
from pyrt.materials import dispatch
from pyrt.geometry.surface import SurfaceBatch
from pyrt.materials import CosineQuery
from pyrt.shaders.vec import dot, normalize


def _random_batch(n, seed):
    rng = np.random.default_rng(seed)
    ns = normalize(rng.normal(size=(n, 3)))
    wo = normalize(rng.normal(size=(n, 3)))
    wo = np.where((dot(wo, ns) < 0)[:, None], -wo, wo)      # the viewer is on the shading normal's side
    wi = normalize(rng.normal(size=(n, 3)))                 # about half below the horizon
    uv = rng.random((n, 2))
    surf = SurfaceBatch(p=rng.normal(size=(n, 3)), ng=ns, ns=ns, wo=wo, front=np.ones(n, bool), uv=uv,
                        duvdx=np.zeros((n, 2)), duvdy=np.zeros((n, 2)))
    return surf, wi


MATERIALS = {
    "lambert": pyrt.Lambert(albedo=(0.7, 0.5, 0.2)),
    "lambert_textured": pyrt.Lambert(albedo=pyrt.CheckerTexture((0.1, 0.2, 0.3), (0.9, 0.8, 0.7), scale=4)),
    "blinn_phong": pyrt.BlinnPhong(kd=0.5, ks=0.3, exponent=60),
    "blinn_phong_rough": pyrt.BlinnPhong(kd=(0.2, 0.3, 0.4), ks=(0.5, 0.4, 0.3), exponent=1.5),
    "blinn_phong_textured": pyrt.BlinnPhong(kd=pyrt.CheckerTexture(0.1, 0.6, scale=3), ks=0.3,
                                            exponent=pyrt.CheckerTexture(2.0, 200.0, scale=5)),
}


@pytest.mark.parametrize("name", sorted(MATERIALS))
@pytest.mark.parametrize("lanes", ["all", "some"])
def test_cosine_path_equals_local_frame_f_cos(name, lanes):
    mat = MATERIALS[name]
    surf, wi = _random_batch(4000, seed=len(name))
    ref = mat.f_cos(surf.to_local(surf.wo), surf.to_local(wi), surf)
    sel = None if lanes == "all" else np.flatnonzero(np.arange(surf.n_hits) % 3 == 1)
    wi_q = wi if sel is None else wi[sel]
    ns = surf.ns if sel is None else surf.ns[sel]
    wo = surf.wo if sel is None else surf.wo[sel]
    val = mat.f_cos_cosines(CosineQuery(surf, sel, wi_q, dot(wi_q, ns), dot(wo, ns)))
    expect = ref if sel is None else ref[sel]
    assert val.shape == expect.shape
    assert np.count_nonzero(expect.max(axis=1) > 0) > 0.3 * len(expect)    # lit lanes and below-horizon
    assert np.count_nonzero(expect.max(axis=1) == 0) > 0.3 * len(expect)   # lanes both exercised
    np.testing.assert_allclose(val, expect, rtol=1e-9, atol=1e-14)


def test_isotropic_subclass_may_not_override_f_cos():
    """The fast path is derived by construction: f_cos of an IsotropicMaterial is defined from f_cos_cosines,
    so a subclass that overrode only f_cos would make the two disagree; it is refused at class creation."""
    with pytest.raises(TypeError, match="f_cos_cosines"):
        class Tinted(pyrt.Lambert):
            def f_cos(self, wo, wi, ctx):
                return 0.5 * super().f_cos(wo, wi, ctx)

    class Dimmed(pyrt.Lambert):          # overriding the cosine kernel changes both paths
        def f_cos_cosines(self, q):
            return 0.5 * super().f_cos_cosines(q)

    surf, wi = _random_batch(200, seed=1)
    surf.__dict__["material_id"] = np.zeros(200, dtype=np.int64)
    batch = dispatch.BSDFBatch(surf, [Dimmed(albedo=0.6)])
    assert batch.cosine_path == {0: True}
    idx = np.arange(200)
    full = pyrt.Lambert(albedo=0.6).f_cos(surf.to_local(surf.wo), surf.to_local(wi), surf)
    np.testing.assert_allclose(batch.f_cos(idx, wi), 0.5 * full, rtol=1e-12, atol=1e-15)
    assert not dispatch.BSDFBatch(surf, [pyrt.Mirror()]).cosine_path[0]
    assert not dispatch.BSDFBatch(surf, [pyrt.Phong()]).cosine_path[0]


def test_render_is_the_same_with_and_without_the_fast_path(monkeypatch):
    cam = pyrt.Camera(position=(0, 1.5, 3), target=(0, 0.5, 0), fov=45, width=48, height=36, spp=2)
    scene = pyrt.Scene(cam)
    scene.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.2, 0.8, scale=6)), name="floor")
    scene.add_sphere((0, 0.6, 0), 0.6, MATERIALS["blinn_phong_textured"], subdivisions=3, name="ball")
    scene.add_sphere((1.2, 0.4, 0.3), 0.4, pyrt.Phong(kd=0.4, ks=0.3, exponent=20), subdivisions=3, name="phong")
    scene.add_light(pyrt.PointLight((2, 4, 2), intensity=30))
    scene.add_light(pyrt.DirectionalLight((-0.3, -1, -0.4), 1.5))
    fast = pyrt.render(scene, seed=3)
    monkeypatch.setattr(dispatch, "IsotropicMaterial", type("NoMaterialIsIsotropic", (), {}))
    slow = pyrt.render(scene, seed=3)
    assert fast.max() > 0.1
    np.testing.assert_allclose(fast, slow, rtol=1e-5, atol=1e-7)   # float32 image


@pytest.mark.parametrize("order", ["sorted_by_material", "interleaved"])
def test_bsdf_batch_dispatch_matches_per_material_evaluation(order):
    """BSDFBatch.f_cos on any query (sorted, with duplicates, unsorted) equals each material's own f_cos,
    whether the batch's hits are ordered by material (contiguous dispatch) or interleaved."""
    mats = [MATERIALS["lambert_textured"], pyrt.Phong(kd=0.4, ks=0.3, exponent=20), MATERIALS["blinn_phong"]]
    surf, wi = _random_batch(3000, seed=7)
    mid = np.arange(3000) % 3 if order == "interleaved" else np.repeat([0, 1, 2], 1000)
    surf.material_id = mid
    surf.__dict__["material_id"] = mid
    batch = dispatch.BSDFBatch(surf, mats)
    assert batch.contiguous == (order == "sorted_by_material")
    rng = np.random.default_rng(0)
    queries = [np.arange(3000), np.flatnonzero(rng.random(3000) < 0.6), np.flatnonzero(rng.random(3000) < 0.1),
               np.sort(rng.integers(0, 3000, 500)),              # duplicates
               rng.permutation(3000)[:800]]                      # unsorted
    for idx in queries:
        got = batch.f_cos(idx, wi[idx])
        want = np.zeros_like(got)
        for k, mat in enumerate(mats):
            sel = np.flatnonzero(mid[idx] == k)
            sub = surf.subset(idx[sel])
            want[sel] = mat.f_cos(sub.to_local(sub.wo), sub.to_local(wi[idx[sel]]), sub)
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-14)
