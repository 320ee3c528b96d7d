"""The compiled environment (:mod:`pyrt.lights.compiled_env`) against the NumPy environments and light.

Every function runs compiled (``numba.njit`` loops) on the record :func:`pack_environment` packs, for constant and
lat-long maps (bilinear and nearest filters, float32 and float64 images, a rotation, an intensity, a width that is
not a power of two, a map with nothing above its mean, an all-black map) and lights (compensated or not, power or
balance heuristic, equal and unequal sample counts):

- ``radiance`` equals :meth:`Environment.radiance` (1e-6 relative, 1e-12 absolute) on random directions, the poles,
  the seam and the texel centres;
- the same ``u`` gives the same world direction and pdf as :meth:`Environment.sample`, ``sample_compensated`` and
  :meth:`EnvironmentLight.mis_sample` (``u`` at 0 and just below 1 included), and the pdfs equal ``pdf``,
  ``pdf_compensated`` and ``mis_pdf`` on random and sampled directions; ``mis_weights`` equals the light's;
- a chi-square test of the compiled samplers against their compiled pdfs, in the map's (u, v) over cells aligned
  with the tables' cells (rejected at p < 1e-4), which fails a sampler held to the wrong table's pdf.
- the guided table search gives the full search's cells everywhere (bucket edges, just below them, outside
  [0, 1)); a light sample's carried (u, v) are its direction's up to rounding; the packed data is built once.
"""
import math

import numba
import numpy as np
import pytest
from scipy import stats

import pyrt
from pyrt.lights import compiled_env as CE
from pyrt.lights import compiled_tables as CT
from pyrt.lights.environment import procedural_sky

pytestmark = pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning",
                                        "ignore:divide by zero encountered:RuntimeWarning")


def _hdr(h, w, seed, dtype=np.float32):
    """A random HDR map with a few bright texels (its compensated table is not empty)."""
    rng = np.random.default_rng(seed)
    img = rng.random((h, w, 3)) * 0.5
    img[rng.integers(0, h, 3), rng.integers(0, w, 3)] = (40.0, 30.0, 20.0)
    return img.astype(dtype)


ENVS = {
    "sky": lambda: pyrt.LatLongEnvironment(procedural_sky(64, 32)),
    "sky_nearest": lambda: pyrt.LatLongEnvironment(procedural_sky(64, 32), filter="nearest"),
    "rotated": lambda: pyrt.LatLongEnvironment(procedural_sky(64, 32), rotate=[(30.0, [0, 1, 0]), (20.0, [1, 0, 0.3])],
                                               intensity=2.5),
    "f64_odd": lambda: pyrt.LatLongEnvironment(_hdr(20, 48, 1, np.float64), rotate=(-70.0, [0.2, 1.0, 0.1])),
    "f64_odd_nearest": lambda: pyrt.LatLongEnvironment(_hdr(20, 48, 2, np.float64), filter="nearest"),
    "flat": lambda: pyrt.LatLongEnvironment(np.full((8, 16, 3), 0.7, dtype=np.float32)),
    "flat_nearest": lambda: pyrt.LatLongEnvironment(np.full((8, 16, 3), 0.7, dtype=np.float32), filter="nearest"),
    "black": lambda: pyrt.LatLongEnvironment(np.zeros((8, 16, 3), dtype=np.float32)),
    "black_nearest": lambda: pyrt.LatLongEnvironment(np.zeros((8, 16, 3), dtype=np.float32), filter="nearest"),
    "constant": lambda: pyrt.ConstantEnvironment((0.3, 0.5, 0.7), intensity=1.5, rotate=(40.0, [1, 1, 0])),
}
NAMES = sorted(ENVS)
LIGHTS = {
    "default": {},
    "full_power": {"compensate": False},
    "balance_counts": {"heuristic": "balance", "n_samples": 2, "bsdf_samples": 3},
    "power_counts": {"n_samples": 4, "bsdf_samples": 1},
}


def _pack(env, light=None):
    tag, rec, data = CE.pack_environment(env, light)
    return tag, np.ascontiguousarray(rec), np.ascontiguousarray(data)


@numba.njit
def _radiance_many(tag, rec, data, d, out):
    for k in range(d.shape[0]):
        out[k, 0], out[k, 1], out[k, 2] = CE.radiance(tag, rec, data, d[k, 0], d[k, 1], d[k, 2])


@numba.njit
def _sample_many(which, tag, rec, data, u, out):
    for k in range(u.shape[0]):
        if which == 0:
            r = CE.sample(tag, rec, data, u[k, 0], u[k, 1])
        elif which == 1:
            r = CE.sample_compensated(tag, rec, data, u[k, 0], u[k, 1])
        else:
            r = CE.mis_sample(tag, rec, data, u[k, 0], u[k, 1])
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = r


@numba.njit
def _pdf_many(which, tag, rec, data, d, out):
    for k in range(d.shape[0]):
        if which == 0:
            out[k] = CE.pdf(tag, rec, data, d[k, 0], d[k, 1], d[k, 2])
        elif which == 1:
            out[k] = CE.pdf_compensated(tag, rec, data, d[k, 0], d[k, 1], d[k, 2])
        else:
            out[k] = CE.mis_pdf(tag, rec, data, d[k, 0], d[k, 1], d[k, 2])


@numba.njit
def _weights_many(rec, pl, pb, out):
    for k in range(pl.shape[0]):
        out[k, 0], out[k, 1] = CE.mis_weights(rec, pl[k], pb[k])


@numba.njit
def _missed_many(tag, rec, data, d, primary, out):
    for k in range(d.shape[0]):
        out[k, 0], out[k, 1], out[k, 2] = CE.missed(tag, rec, data, d[k, 0], d[k, 1], d[k, 2], primary)


def _radiance(env, d):
    tag, rec, data = _pack(env)
    out = np.zeros((d.shape[0], 3))
    _radiance_many(tag, rec, data, np.ascontiguousarray(d), out)
    return out


def _sample(which, env, u, light=None):
    tag, rec, data = _pack(env, light)
    out = np.zeros((u.shape[0], 4))
    _sample_many(which, tag, rec, data, np.ascontiguousarray(u, dtype=np.float64), out)
    return out[:, :3], out[:, 3]


def _pdf(which, env, d, light=None):
    tag, rec, data = _pack(env, light)
    out = np.zeros(d.shape[0])
    _pdf_many(which, tag, rec, data, np.ascontiguousarray(d, dtype=np.float64), out)
    return out


def _close(got, want):
    got, want = np.asarray(got, dtype=np.float64), np.asarray(want, dtype=np.float64)
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-12)


def _directions(env, n=4000, seed=11, pdf=False):
    """Random unit world directions, the poles, the seam (u = 0) and the texel centres of a lat-long map (a quarter
    texel off them for the pdfs, or for a rotated map: the dual cells meet at the texel centres, where the density
    jumps, and a direction there is rounded differently by NumPy's ``arccos`` / ``arctan2`` and matrix product than
    by the scalar ``math.acos`` / ``math.atan2`` and sums: another cell)."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    special = [(0, 1, 0), (0, -1, 0), (0, 0, -1), (0, 0, 1), (1, 0, 0), (-1, 0, 0), (0, 0.6, -0.8), (0, -0.6, -0.8),
               (1e-12, 0.3, -1.0), (-1e-12, 0.3, -1.0)]
    d = np.concatenate([d, np.array(special, dtype=np.float64)])
    if hasattr(env, "image"):
        h, w = env.image.shape[:2]
        dv = 0.0 if np.array_equal(env.rotation, np.eye(3)) and not pdf else 0.25
        uu, vv = np.meshgrid((np.arange(w) + 0.5 + dv) / w, (np.arange(h) + 0.5 + dv) / h)
        local = pyrt.shaders.envmap.latlong_uv_to_dir(np.stack([uu.ravel(), vv.ravel()], 1))
        d = np.concatenate([d, env.to_world(local)])
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def _us(n=4000, seed=5):
    rng = np.random.default_rng(seed)
    u = rng.random((n, 2))
    edge = [0.0, 1e-12, 0.5, 1.0 - 1e-12, np.nextafter(1.0, 0.0)]
    return np.concatenate([u, np.array([(a, b) for a in edge for b in edge])])


# ----------------------------------------------------------------------------------------- equality with NumPy

@pytest.mark.parametrize("name", NAMES)
def test_radiance_equals_numpy(name):
    env = ENVS[name]()
    d = _directions(env)
    _close(_radiance(env, d), env.radiance(d))


@pytest.mark.parametrize("name", NAMES)
def test_same_u_gives_the_numpy_direction_and_pdf(name):
    env = ENVS[name]()
    u = _us()
    for which, numpy_sample in ((0, env.sample), (1, env.sample_compensated)):
        d, p = _sample(which, env, u)
        want_d, want_p = numpy_sample(u)
        _close(d, want_d)
        _close(p, want_p)


@pytest.mark.parametrize("name", NAMES)
def test_pdfs_equal_numpy(name):
    env = ENVS[name]()
    d = np.concatenate([_directions(env, pdf=True), env.sample(_us(800, 6))[0],
                        env.sample_compensated(_us(800, 7))[0]])
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    _close_pdf(env, d, _pdf(0, env, d), env.pdf(d))
    _close_pdf(env, d, _pdf(1, env, d), env.pdf_compensated(d))


def _close_pdf(env, d, got, want):
    """:func:`_close`, but in a rotated map only at directions more than 1e-6 from the map's poles: NumPy's matrix
    product rounds the rotated direction's last bits differently, and near a pole (``sin theta`` = 1e-9 from the
    table's samples) that moves the longitude by ``1e-16 / sin theta`` radians, to another cell."""
    if not np.array_equal(env.rotation, np.eye(3)):
        loc = env.to_local(d)
        far = np.sqrt(loc[:, 0] ** 2 + loc[:, 2] ** 2) > 1e-6
        assert np.all(np.isfinite(got)) and np.all(got >= 0)
        got, want = got[far], want[far]
    _close(got, want)


@pytest.mark.parametrize("light_kw", sorted(LIGHTS))
@pytest.mark.parametrize("name", ["sky", "f64_odd_nearest", "flat", "constant"])
def test_mis_sample_pdf_and_weights_equal_the_light(name, light_kw):
    env = ENVS[name]()
    light = pyrt.EnvironmentLight(env, **LIGHTS[light_kw])
    u = _us(1500, 8)
    d, p = _sample(2, env, u, light)
    want_d, want_p = light.mis_sample(u)
    _close(d, want_d)
    _close(p, want_p)
    dirs = np.concatenate([_directions(env, 1000, pdf=True), want_d])
    dirs = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    pl = _pdf(2, env, dirs, light)
    _close(pl, light.mis_pdf(dirs))
    rng = np.random.default_rng(3)
    pb = rng.random(pl.shape[0]) * 2.0
    pb[:5] = 0.0
    pl[:3] = 0.0
    out = np.zeros((pl.shape[0], 2))
    _weights_many(_pack(env, light)[1], pl, pb, out)
    w_l, w_b = light.mis_weights(pl, pb)
    np.testing.assert_allclose(out[:, 0], w_l, rtol=1e-12, atol=0)
    np.testing.assert_allclose(out[:, 1], w_b, rtol=1e-12, atol=0)


@numba.njit
def _fused_many(tag, rec, data, d, out, sep):
    for k in range(d.shape[0]):
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = CE.radiance_mis_pdf(tag, rec, data, d[k, 0], d[k, 1], d[k, 2])
        sep[k, 0], sep[k, 1], sep[k, 2] = CE.radiance(tag, rec, data, d[k, 0], d[k, 1], d[k, 2])
        sep[k, 3] = CE.mis_pdf(tag, rec, data, d[k, 0], d[k, 1], d[k, 2])


@pytest.mark.parametrize("light_kw", sorted(LIGHTS))
@pytest.mark.parametrize("name", NAMES)
def test_radiance_and_pdf_at_once_equal_the_two_calls(name, light_kw):
    """``radiance_mis_pdf`` (a BSDF sample's lookup and light density, the direction's (u, v) computed once) gives
    bit for bit what ``radiance`` and ``mis_pdf`` give."""
    env = ENVS[name]()
    tag, rec, data = _pack(env, pyrt.EnvironmentLight(env, **LIGHTS[light_kw]))
    d = _directions(env, 1500, pdf=True)
    d = np.ascontiguousarray(d / np.linalg.norm(d, axis=1, keepdims=True))
    out, sep = np.zeros((d.shape[0], 4)), np.zeros((d.shape[0], 4))
    _fused_many(tag, rec, data, d, out, sep)
    np.testing.assert_array_equal(out, sep)
    assert np.all(np.isfinite(out))


def test_missed_rays_see_the_background_only_from_the_camera():
    env = pyrt.LatLongEnvironment(procedural_sky(32, 16), hide_background=True, background=(0.1, 0.2, 0.3))
    tag, rec, data = _pack(env)
    d = _directions(env, 50)
    out = np.zeros((d.shape[0], 3))
    _missed_many(tag, rec, data, d, True, out)
    np.testing.assert_array_equal(out, np.broadcast_to([0.1, 0.2, 0.3], out.shape))
    _missed_many(tag, rec, data, d, False, out)
    _close(out, env.radiance(d))


def test_other_environments_have_no_compiled_form():
    cube = pyrt.CubeMapEnvironment.example()
    assert CE.pack_environment(cube) is None

    class Tinted(pyrt.LatLongEnvironment):
        pass
    assert CE.pack_environment(Tinted(procedural_sky(16, 8))) is None


def test_the_record_layout(rng):
    env = pyrt.LatLongEnvironment(procedural_sky(16, 8), intensity=3.0)
    light = pyrt.EnvironmentLight(env, heuristic="balance", n_samples=3, bsdf_samples=2, compensate=False)
    tag, rec, data = CE.pack_environment(env, light)
    assert tag == CE.LATLONG_BILINEAR and rec.shape == (CE.RECORD,)
    assert (rec[CE.R_H], rec[CE.R_W], rec[CE.R_ROWS], rec[CE.R_F32]) == (8, 16, 9, 1)
    assert (rec[CE.R_INTENSITY], rec[CE.R_COMPENSATE], rec[CE.R_BETA], rec[CE.R_NL], rec[CE.R_NB]) == (3, 0, 1, 3, 2)
    np.testing.assert_array_equal(data[:8 * 16 * 3], env.image.astype(np.float64).ravel())
    o = int(rec[CE.R_TABLE])
    dist = env.distribution
    np.testing.assert_array_equal(data[o:o + dist.func.size], dist.func.ravel())
    # the compensated table: func (9, 16), cdf_cond (9, 17), cdf_marg (10,), the rows' guides (9, 4 + 1) and the
    # marginal's (2 + 1,)
    assert (CT.guide_buckets(16), CT.guide_buckets(9)) == (4, 2)
    assert rec[CE.R_HAS_C] == 1 and int(rec[CE.R_C_TABLE]) + 9 * 16 + 9 * 17 + 10 + 9 * 5 + 3 == data.size


def test_the_packed_data_is_built_once_per_map():
    """A second packing of the same map and tables reuses the data (only the record is new)."""
    env = pyrt.LatLongEnvironment(procedural_sky(16, 8))
    light = pyrt.EnvironmentLight(env)
    _, rec1, data1 = CE.pack_environment(env, light)
    _, rec2, data2 = CE.pack_environment(env, light)
    assert data2 is data1 and rec2 is not rec1
    np.testing.assert_array_equal(rec1, rec2)
    other = pyrt.LatLongEnvironment(procedural_sky(16, 8))
    assert CE.pack_environment(other, pyrt.EnvironmentLight(other))[2] is not data1


@pytest.mark.parametrize("n", [1, 3, 4, 7, 8, 16, 17, 48, 257, 512, 1000])
def test_guide_buckets_are_powers_of_two_of_about_four_cells(n):
    g = CT.guide_buckets(n)
    assert g & (g - 1) == 0 and (g == 1 or 4 * g <= n < 8 * g)


@pytest.mark.parametrize("name", [n for n in NAMES if n != "constant"])
def test_the_guided_search_finds_the_cells_of_the_full_search(name, rng):
    """``_find_guided`` (the search from a guide table's bucket) gives the cell of ``_find`` (the whole row's
    search) for every table of the map: on random ``u``, on every bucket's edge and just below it, at 0 and just
    below 1, and outside [0, 1) (where it falls back to the full search)."""
    env = ENVS[name]()
    tag, rec, data = _pack(env, pyrt.EnvironmentLight(env))
    rows, w = int(rec[CE.R_ROWS]), int(rec[CE.R_W])
    gc, gm = CT.guide_buckets(w), CT.guide_buckets(rows)
    tables = [int(rec[CE.R_TABLE])] + ([int(rec[CE.R_C_TABLE])] if rec[CE.R_HAS_C] else [])
    for o in tables:
        o_cond = o + rows * w
        o_marg = o_cond + rows * (w + 1)
        o_gc = o_marg + rows + 1
        o_gm = o_gc + rows * (gc + 1)
        for g, search in ((gm, [(o_marg, rows, 0.0, o_gm)]),
                          (gc, [(o_cond + r * (w + 1), w, float(r), o_gc + r * (gc + 1)) for r in range(rows)])):
            edges = np.arange(g + 1) / g
            us = np.concatenate([rng.random(64), edges, np.nextafter(edges, 0.0), [np.nextafter(1.0, 0.0), -0.25,
                                                                                   1.5]])
            for oo, n, shift, og in search:
                for u in us:
                    assert CT._find_guided(data, oo, n, shift, u, og, g) == CT._find(data, oo, n, shift, u), (oo, u)


@pytest.mark.parametrize("name", NAMES)
def test_a_light_sample_carries_its_lookup_coordinates(name):
    """``mis_sample_uv``: the direction and pdf of ``mis_sample`` bit for bit, and the environment-frame direction
    and lat-long (u, v) that ``lookup_coords`` computes from it, up to rounding, away from the poles (the light stage
    looks the sample's radiance up at these)."""
    env = ENVS[name]()
    light = pyrt.EnvironmentLight(env)
    tag, rec, data = _pack(env, light)
    for u0, u1 in _us(600):
        a = CE.mis_sample(tag, rec, data, u0, u1)
        b = CE.mis_sample_uv(tag, rec, data, u0, u1)
        assert tuple(b[:4]) == tuple(a)
        if tag == CE.CONSTANT:
            assert tuple(b[4:]) == (0.0,) * 5
            continue
        c = CE.lookup_coords(tag, rec, *a[:3])
        np.testing.assert_allclose(b[4:7], c[:3], rtol=0, atol=1e-12)
        np.testing.assert_allclose(CE.latlong_uv_to_dir(b[7], b[8]), b[4:7], rtol=0, atol=1e-12)
        if math.hypot(c[0], c[2]) > 1e-6:     # (at a pole every u is the same direction, and acos(y) ill-conditioned)
            du = abs(c[3] - b[7])
            assert min(du, 1.0 - du) < 1e-12 and abs(c[4] - b[8]) < 1e-12


# ----------------------------------------------------------------------------------------- chi-square

def _uv_cells(env, table_rows):
    """The (u, v) edges of the table's cells: dual cells (between texel centres, half rows at the poles) for a
    bilinear map, texels for a nearest one."""
    h, w = env.image.shape[:2]
    if table_rows == h + 1:
        u_edges = (np.arange(w + 1) + 0.5) / w
        v_edges = np.clip((np.arange(h + 2) - 0.5) / h, 0.0, 1.0)
    else:
        u_edges = np.arange(w + 1) / w
        v_edges = np.arange(h + 1) / h
    return u_edges, v_edges


def _chi_square_p(env, which_sample, which_pdf, n=300_000):
    """p-value of the compiled sampler ``which_sample`` (0 full, 1 compensated table) against the compiled pdf
    ``which_pdf``: samples histogrammed over the table's cells in the map's (u, v) (u taken modulo 1 from the
    first edge), expected counts the pdf times the Jacobian ``2 pi^2 sin theta`` integrated by 4 x 4 Gauss points
    per cell; cells expecting < 5 pooled."""
    tag, rec, data = _pack(env)
    d, p = _sample(which_sample, env, np.random.default_rng(17).random((n, 2)))
    uv = pyrt.shaders.envmap.latlong_dir_to_uv(env.to_local(d))
    u_edges, v_edges = _uv_cells(env, int(rec[CE.R_ROWS]))
    u = (uv[:, 0] - u_edges[0]) % 1.0 + u_edges[0]
    obs, _, _ = np.histogram2d(uv[:, 1], u, bins=[v_edges, u_edges])
    g, gw = np.polynomial.legendre.leggauss(4)
    vs = (v_edges[:-1, None] + (v_edges[1:] - v_edges[:-1])[:, None] * (g + 1) / 2)      # (rows, 4)
    us = (u_edges[:-1, None] + (u_edges[1:] - u_edges[:-1])[:, None] * (g + 1) / 2)      # (cols, 4)
    V, U = np.meshgrid(vs.ravel(), us.ravel(), indexing="ij")
    pts = pyrt.shaders.envmap.latlong_uv_to_dir(np.stack([U.ravel() % 1.0, V.ravel()], 1))
    dens = _pdf(which_pdf, env, env.to_world(pts)) * 2 * math.pi ** 2 * np.sin(math.pi * V.ravel())
    dens = dens.reshape(vs.shape[0], 4, us.shape[0], 4)
    wv = (gw[None, :] * (v_edges[1:] - v_edges[:-1])[:, None] / 2)
    wu = (gw[None, :] * (u_edges[1:] - u_edges[:-1])[:, None] / 2)
    exp = np.einsum("aibj,ai,bj->ab", dens, wv, wu) * n
    obs, exp = obs.ravel(), exp.ravel()
    assert abs(exp.sum() / n - 1.0) < 1e-3 or which_pdf != which_sample
    small = exp < 5
    o = np.append(obs[~small], obs[small].sum())
    e = np.append(exp[~small], exp[small].sum())
    keep = e > 0
    assert np.all(o[~keep] == 0), "samples where the pdf is zero"
    chi2 = np.sum((o[keep] - e[keep]) ** 2 / e[keep])
    return stats.chi2.sf(chi2, keep.sum() - 1)


@pytest.mark.parametrize("name", ["sky", "sky_nearest", "rotated", "f64_odd", "f64_odd_nearest"])
@pytest.mark.parametrize("which", [0, 1])
def test_compiled_sampler_follows_its_compiled_pdf_chi_square(name, which):
    assert _chi_square_p(ENVS[name](), which, which) > 1e-4


def test_the_chi_square_harness_rejects_the_wrong_table():
    """The full table's samples against the compensated table's pdf: rejected."""
    assert _chi_square_p(ENVS["f64_odd"](), 0, 1) < 1e-6
