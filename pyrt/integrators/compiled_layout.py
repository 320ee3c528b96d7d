"""The compiled tile kernel's data layout: the per-packet scratch, the camera record, the option arrays, the
specular stack, random dimensions, the per-call buffers and table pointers, the packets' additions to the film
(fixed spp) and to an adaptive pass's sums, and the decorators of its functions
(:mod:`pyrt.integrators.compiled_kernel`, :mod:`pyrt.integrators.compiled_lighting`)."""
from __future__ import annotations

import math

import numba

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below (and those of the modules they inline) run

import numpy as np  # noqa: E402

from pyrt.core import unmanaged as U  # noqa: E402
from pyrt.core.unmanaged import keep_alive  # noqa: E402
from pyrt.geometry import embree_jit as E  # noqa: E402
from pyrt.shaders import jit_sampling as JS  # noqa: E402

#: pixels per tile side
TILE = 8
#: lanes of the per-packet scratch (the widest packet)
LANES = 16
#: per-packet scratch layout (float64, fields of :data:`LANES` lanes: field ``f`` of lane ``l`` at ``f * LANES + l``):
#: ray direction, hit point, geometric normal (viewer side), shading normal, interpolated vertex normal (= ng on flat
#: faces), terminator-lifted point, local-bound magnitudes, front flag, material (-1: a miss), albedo, radiance, the
#: current light's unshadowed contribution and whether its shadow ray is traced
V_D, V_P, V_NG, V_NS, V_NV, V_LIFT = 0, 3, 6, 9, 12, 15
V_MAG, V_MAG_LIFT, V_FRONT, V_MAT = 18, 19, 20, 21
V_A, V_L, V_F, V_LIT = 22, 25, 28, 31
#: the light stage's fields: the cosines ``ns.wo`` (per hit), ``ns.wi`` and ``wi.wo`` (per light), the light's
#: irradiance scale and whether the light can reach the hit's side (before the BSDF)
V_COSO, V_COSI, V_COSIO, V_S, V_GOK = 32, 33, 34, 35, 36
#: coverage (:func:`pyrt.integrators.compiled_coverage.cover_packet`): the camera ray's distance to its last
#: re-trace origin (0: none; -1: dropped), between the camera query and the surface stage's end; it shares
#: :data:`V_S`, which the light stages write only after that
V_TB = V_S
#: the shadow ray: origin, direction, tmax
V_SO, V_WI, V_TMAX = 37, 40, 43
#: the camera ray's hit distance (``inf``: a miss; the depth AOV)
V_T = 44
#: ray differentials (:mod:`pyrt.integrators.compiled_diffs`; written only with ``opts[O_DIFFS]``): the ray's offset
#: rays (x origin, x direction, y origin, y direction), then the hit's dp/dx, dp/dy, dn/dx, dn/dy
V_RAY, V_DP = 45, 57
#: the environment stage's lanes between its two passes (:func:`pyrt.integrators.compiled_lighting.env_stage`):
#: direction, BSDF weight, direction in the environment's frame, density, lat-long (u, v), whether it counts
V_EWI, V_EW, V_ELOC, V_EPDF, V_EUV, V_EOK = 69, 72, 75, 78, 79, 81
#: the rest of a hit's inputs after its albedo (:func:`pyrt.materials.compiled.albedo_at`): GLTF's base colour,
#: metallic, roughness and occlusion (written for GLTF hits only, read only for them: :func:`lane_inputs`)
V_X = 82
#: the environment's light samples in the packet stage (:mod:`pyrt.integrators.compiled_env_stage`): the two
#: sample numbers, the table cell (row, column), the in-cell offsets, the cell's four corner luminances, its func
V_EU, V_ECELL, V_EFF, V_ECORNER, V_EFN = 88, 90, 92, 94, 98
#: the material (plus one) of a camera hit that is lit and continued lane by lane (:func:`pyrt.integrators.
#: compiled_hit.set_aside`: a glossy hit of the glossy integrator, or a hit lit by one chosen light), not by the
#: packet's light stages; 0 elsewhere
V_GL = 99
#: a camera hit on a blend surface (:func:`pyrt.integrators.compiled_coverage.cover_packet`): its weight (the coverage
#: alpha ``a``, 0 < a < 1; 1 for every other lane) and the layer its continuation past the surface starts at
V_BW, V_BL = 100, 101
#: the rest of a GLTF hit's inputs (:func:`pyrt.materials.compiled.albedo_at`): its specular weight and dielectric F0
#: (written and read as :data:`V_X`)
V_XS = 102
#: the rest of a coated GLTF hit's inputs (:data:`pyrt.materials.compiled.COAT`): its clear coat ``c``, the coat's
#: alpha and the coat's normal in the shading frame (written and read as :data:`V_X`)
V_XC = 106
#: fields of the scratch
V_SIZE = 111
#: camera record layout (float64)
C_POS, C_FWD, C_RIGHT, C_UP, C_TAN, C_W, C_H, C_JITTER, C_K, C_AX = 0, 3, 6, 9, 12, 13, 14, 15, 16, 17
#: length of the camera record
N_CAM = 18
#: integer options
O_SEED, O_SPP, O_MAX_DEPTH, O_SPLIT, O_TERMINATOR, O_NLIGHTS, O_SPP_LO, O_FALLBACK, O_GRID, O_ENV, O_AOV = range(11)
#: 1 when a texture reads footprints (the rays carry differentials), 1 when a material has a normal map (2 when
#: besides a mesh has vertex tangents: the maps read them there), 1 when a fixed-spp render sums the squared radiance
#: too (the film's second moment)
O_DIFFS, O_NMAPS, O_SQ = 11, 12, 13
#: coverage (:mod:`pyrt.integrators.compiled_coverage`): 0 none, 1 some material culls back faces, 2 some material
#: is an alpha mask; and the most surfaces a ray skips (:data:`pyrt.integrators.coverage.MAX_LAYERS`)
O_COVER, O_LAYERS = 14, 15
#: the glossy integrator (:mod:`pyrt.integrators.glossy`; 0 with Whitted): BSDF samples per glossy camera hit, the
#: bounces that spawn glossy rays (``glossy_depth``); the bounce from which hits are lit by one chosen delta light
#: (``light_select_depth``; -1: never)
O_GLOSSY_N, O_GLOSSY_DEPTH, O_SELECT = 16, 17, 18
#: the light samples per hit of the environment light whose map the glossy integrator samples at glossy hits (0: none;
#: escaped glossy rays then count the environment with weight 1)
O_GLOSSY_ENV = 19
#: 1: Russian roulette below the throughput cutoff (``roulette=True``, :func:`pyrt.integrators.compiled_hit.survive`),
#: 0: such rays are dropped
O_ROULETTE = 20
#: transparent shadows (:mod:`pyrt.integrators.compiled_shadows`): the most surfaces a shadow ray crosses
#: (:data:`pyrt.integrators.shadows.MAX_INTERFACES`, :data:`pyrt.integrators.coverage.MAX_LAYERS` in a scene with
#: masks); 0: off (dielectrics block)
O_TRANSPARENT = 21
#: 1 when the rays carry interface stacks (nested dielectrics or absorption: :mod:`pyrt.integrators.compiled_media`)
O_MEDIA = 22
#: length of the integer options
N_OPTS = 23
#: consecutive tiles of a call's list that one thread renders with one set of packet buffers
#: (:func:`pyrt.integrators.compiled_kernel.render_tiles`; also the unit of the threads' dynamic scheduling)
TILES_PER_TASK = 4
#: the AOV sums per pixel (``opts[O_AOV]`` 1): depth, depth weight (samples that hit), normal (3), albedo (3)
N_AOV = 8
#: float options
F_CUTOFF, F_BG, F_AMBIENT = 0, 1, 4
#: the glossy integrator's ``glossy_threshold`` (lobes of a larger alpha count as diffuse) and ``glossy_clamp``
#: (``inf``: none)
F_GLOSSY_T, F_GLOSSY_CLAMP = 7, 8
#: where the float options hold the environment's record (:data:`pyrt.lights.compiled_env.RECORD` entries; its tag
#: is ``opts[O_ENV]``, 0: none)
F_ENV = 9
#: ray counters per tile
N_PRIMARY, N_SECONDARY, N_SHADOW, N_NONFINITE = 0, 1, 2, 3
#: the largest stack of pending specular rays a sample can need (2 per bounce below the split depth)
STACK = 64
#: words of a stack row: origin, direction, throughput, depth, then (from :data:`STACK_DIFF`, with ``opts[O_DIFFS]``)
#: the ray's differentials (x origin, x direction, y origin, y direction), then (at :data:`STACK_PDF`) the density
#: ``n p`` of a BSDF-sampled (glossy) ray's direction, 0 for a delta ray; then (:data:`STACK_TB`, :data:`STACK_LAYER`)
#: for a blend continuation (:mod:`pyrt.integrators.compiled_coverage`) the distance along the direction from the
#: ray's first origin to the row's origin and the surfaces the ray has skipped or split so far (0 for a spawned ray);
#: then (:data:`STACK_MED`, with ``opts[O_MEDIA]``) the ray's interface stack: its count and up to :data:`MED_K`
#: material ids (:mod:`pyrt.integrators.compiled_media`)
STACK_ROW, STACK_DIFF, STACK_PDF, STACK_TB, STACK_LAYER, STACK_MED = 32, 10, 22, 23, 24, 25
#: the most volumes a ray's interface stack holds; the stack row past the last (row :data:`STACK`) keeps the stack of
#: the ray in hand
MED_K, MED_ROW = 6, STACK
#: Embree's "unbounded" tfar (:data:`pyrt.geometry.accel.T_INFINITE`)
T_INF = 1e37
#: the first random dimension of the glass lobe choice (0, 1: the pixel position)
DIM_LOBE = 2
#: the first random dimension of the area lights' samples at a hit (two per sample, :func:`area_u`; below it, one
#: per light for its Latin-hypercube permutation); each hit of a sample's specular tree has a key of its own
DIM_AREA = 1 << 20
#: the random dimension of a hit's choice of one light (``light_select_depth``), the first of its glossy rays' samples
#: (two per ray, below it one for their Latin-hypercube permutation)
DIM_CHOOSE, DIM_GLOSSY = 1 << 36, 1 << 37
#: the first random dimension of the Russian roulette of a hit's glossy rays (one per ray; a delta ray's roulette
#: draws the sample's next dimension after :data:`DIM_LOBE`, as the lobe choice does)
DIM_ROULETTE = 1 << 38
#: the first random dimension of the environment light's samples at a hit of the specular tree (four per round)
DIM_ENV = 1 << 40
#: adaptive passes key a sample by ``ADAPTIVE_KEYS + 2 index + half`` (:func:`pyrt.shaders.jit.key64`): apart from the
#: fixed-spp renders' sample numbers
ADAPTIVE_KEYS = 1 << 40
#: the largest number of an area light's samples per hit whose dimensions stay apart
MAX_AREA_SAMPLES = 1 << 16

_njit = numba.njit(nogil=True, cache=True, error_model="numpy", forceinline=True)
#: a packet stage whose loop over the lanes should vectorise: compiled as a function of its own (not inlined by
#: Numba), because LLVM does not vectorise such a loop once it sits inside the kernel's loops (measured: an inlined
#: light stage stayed scalar, ~60 cycles a lane); compiled alone it vectorises, and LLVM may still inline the
#: vectorised body. It takes pointers and numbers only, so the call costs no reference counting. Stages and the
#: tile function ask for 512-bit vectors (:func:`pyrt.core.unmanaged.wide_vectors`).
_stage = numba.njit(nogil=True, cache=True, error_model="numpy")


@_njit
def padded_numbers(V, field, lane_s, spp, lane_k32, pair, n, s, count):
    """Each lane's padded sample numbers of dimension pair ``pair`` (:func:`pyrt.shaders.jit_sampling.
    padded_sobol_2d` of its sample ``lane_s[l]`` of its pixel's ``spp`` and its pixel's seed ``lane_k32[l]``) into
    the scratch: ``x0`` into ``field``, ``(s + x1) / count`` into ``field + 1`` (round ``s`` of ``count``: the second
    number stratified over the rounds), ``(0.5, (s + 0.5) / count)`` for the lanes from ``n`` on. The per-pixel hashes
    (:func:`~pyrt.shaders.jit_sampling.padded_keys`) once per run of lanes of one pixel (a packet of one pixel's
    samples: once)."""
    last = lane_k32[0]
    keys = JS.padded_keys(last, pair)
    for lane in range(LANES):
        x0 = x1 = 0.5
        if lane < n:
            if lane_k32[lane] != last:
                last = lane_k32[lane]
                keys = JS.padded_keys(last, pair)
            x0, x1 = JS.padded_sobol_2d_keyed(lane_s[lane], spp, keys)
        V[field * LANES + lane] = x0
        V[(field + 1) * LANES + lane] = (s + x1) / count


@_njit
def lane_vec(V, field, lane):
    """The 3-vector at ``field`` of lane ``lane`` of the packet scratch."""
    return V[field * LANES + lane], V[(field + 1) * LANES + lane], V[(field + 2) * LANES + lane]


@_njit
def lane_inputs(V, lane):
    """The hit inputs (an 18-tuple, :func:`pyrt.materials.compiled.albedo_at`) of lane ``lane``: :data:`V_A`,
    :data:`V_X`, :data:`V_XS` and :data:`V_XC` (stale for a lane whose material is not GLTF: not read then)."""
    return (V[V_A * LANES + lane], V[(V_A + 1) * LANES + lane], V[(V_A + 2) * LANES + lane], V[V_X * LANES + lane],
            V[(V_X + 1) * LANES + lane], V[(V_X + 2) * LANES + lane], V[(V_X + 3) * LANES + lane],
            V[(V_X + 4) * LANES + lane], V[(V_X + 5) * LANES + lane], V[V_XS * LANES + lane],
            V[(V_XS + 1) * LANES + lane], V[(V_XS + 2) * LANES + lane], V[(V_XS + 3) * LANES + lane],
            V[V_XC * LANES + lane], V[(V_XC + 1) * LANES + lane], V[(V_XC + 2) * LANES + lane],
            V[(V_XC + 3) * LANES + lane], V[(V_XC + 4) * LANES + lane])


@_njit
def set_lane_inputs(V, lane, a, gltf):
    """Store the hit inputs ``a`` of lane ``lane``: the albedo, and the rest where ``gltf`` (its material is GLTF)."""
    V[V_A * LANES + lane] = a[0]
    V[(V_A + 1) * LANES + lane] = a[1]
    V[(V_A + 2) * LANES + lane] = a[2]
    if gltf:
        for k in range(6):
            V[(V_X + k) * LANES + lane] = a[3 + k]
        for k in range(4):
            V[(V_XS + k) * LANES + lane] = a[9 + k]
        for k in range(5):
            V[(V_XC + k) * LANES + lane] = a[13 + k]


@_njit
def set_lane_vec(V, field, lane, x):
    """Store the 3-tuple ``x`` at ``field`` of lane ``lane`` of the packet scratch."""
    V[field * LANES + lane] = x[0]
    V[(field + 1) * LANES + lane] = x[1]
    V[(field + 2) * LANES + lane] = x[2]


# ----------------------------------------------------------------------------------------- buffers

@_njit
def geometry_pointers(geo_f, geo_i):
    """The geometry tables (:class:`pyrt.integrators.compiled.CompiledScene`'s ``geo_f``, ``geo_i``) as the tuple of
    pointers :func:`hit_surface` reads: vertices, vertex normals, UVs, face normals, face absmax, face extents
    (float64), faces, mesh face offsets, face materials, face smooth flags (int64), then the vertex colours (RGB per
    vertex, read for materials whose base colour multiplies them: :data:`pyrt.materials.compiled.VERTEX_COLOR`) and
    the vertex tangent frames (``[t, w (n x t)]`` per vertex, :attr:`pyrt.geometry.GeometryTable.tangent_frames`,
    read by normal maps when ``opts[O_NMAPS]`` is 2) (float64; one dummy row where the scene has none)."""
    return (U.pointer(geo_f[0]), U.pointer(geo_f[1]), U.pointer(geo_f[2]), U.pointer(geo_f[3]), U.pointer(geo_f[4]),
            U.pointer(geo_f[5]), U.pointer(geo_i[0]), U.pointer(geo_i[1]), U.pointer(geo_i[2]), U.pointer(geo_i[3]),
            U.pointer(geo_f[6]), U.pointer(geo_f[7]))


@_njit
def packet_buffers(width):
    """The per-call buffers of a kernel entry: the camera and shadow packets (``width`` lanes), the single-ray
    buffer, the packet scratch, the specular stack, each lane's key, pixel and sample, its pixel's keys and raster
    corner. Returned as owners: their pointers come from :func:`buffer_pointers`; :func:`release` at the end of the
    entry keeps them alive until then."""
    return (E.packet_alloc(width), E.packet_alloc(width), E.ray_alloc(), np.zeros(V_SIZE * LANES),
            np.zeros((STACK + 1) * STACK_ROW), np.zeros(LANES, dtype=np.uint64), np.zeros(2 * LANES, dtype=np.int64),
            np.zeros(2 * LANES, dtype=np.uint64), np.zeros(2 * LANES))


@_njit
def buffer_pointers(b):
    """Pointers into :func:`packet_buffers`' owners: packet, shadow packet, ray, scratch, stack, keys, each lane's
    pixel and sample, its pixel's sample key and padded-sample seed, its raster corner (x at ``[l]``, y at
    ``[LANES + l]``)."""
    return (U.pointer(b[0]), U.pointer(b[1]), U.pointer(b[2]), U.pointer(b[3]), U.pointer(b[4]), U.pointer(b[5]),
            U.pointer(b[6]), U.pointer(b[6][LANES:]), U.pointer(b[7]), U.pointer(b[7][LANES:]), U.pointer(b[8]))


@_njit
def table_pointers(env_data, cam, opts, optf, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par, counters):
    """Pointers into a kernel entry's array arguments (they outlive its loops): the environment's record (in the
    float options from :data:`F_ENV`) and data, then the arguments' own in order."""
    return (U.pointer(optf[F_ENV:]), U.pointer(env_data), U.pointer(cam), U.pointer(opts), U.pointer(optf),
            U.pointer(mats_tag), U.pointer(mats_par), U.pointer(tex_tag), U.pointer(tex_par), U.pointer(lights_tag),
            U.pointer(lights_par), U.pointer(counters))


@_njit
def release(b):
    """The last use of :func:`packet_buffers`' owners (Numba frees an array after its last use)."""
    keep_alive(b[0])
    keep_alive(b[1])
    keep_alive(b[2])
    keep_alive(b[3])
    keep_alive(b[4])
    keep_alive(b[5])
    keep_alive(b[6])
    keep_alive(b[7])
    keep_alive(b[8])


@_njit
def film_add(V, lane_pix, n, film_s, film_q, want_sq):
    """Lanes ``[0, n)``'s radiance (:data:`V_L`) added to their pixels' sums, and with ``want_sq`` squares (rows
    ``lane_pix[l]``): a pixel's running sums stay in registers over its run of lanes (they come in pixel order) and
    are stored once per run, the same additions in the same order as one lane at a time (a store per lane made each
    addition wait for the previous one's store)."""
    lane = 0
    while lane < n:
        q = lane_pix[lane] * 3
        s0, s1, s2 = film_s[q], film_s[q + 1], film_s[q + 2]
        q0 = q1 = q2 = 0.0
        if want_sq:
            q0, q1, q2 = film_q[q], film_q[q + 1], film_q[q + 2]
        while lane < n and lane_pix[lane] * 3 == q:
            l0, l1, l2 = lane_vec(V, V_L, lane)
            s0 += l0
            s1 += l1
            s2 += l2
            q0 += l0 * l0
            q1 += l1 * l1
            q2 += l2 * l2
            lane += 1
        film_s[q], film_s[q + 1], film_s[q + 2] = s0, s1, s2
        if want_sq:
            film_q[q], film_q[q + 1], film_q[q + 2] = q0, q1, q2


@_njit
def add_aovs(V, lane, a, q):
    """Lane ``lane``'s first-hit AOVs added to the pixel's row ``a[q:q + N_AOV]``: depth and a count where the
    camera ray hit, the shading normal and the albedo (zeros on a miss), as :meth:`pyrt.core.film.Film.add_block`."""
    t = V[V_T * LANES + lane]
    if math.isfinite(t):
        a[q] += t
        a[q + 1] += 1.0
        ns, alb = lane_vec(V, V_NS, lane), lane_vec(V, V_A, lane)
        for c in range(3):
            a[q + 2 + c] += ns[c]
            a[q + 5 + c] += alb[c]


@_njit
def pass_add(V, lane_pix, n, both, half_b):
    """Lanes ``[0, n)``'s radiance (:data:`V_L`) added to the pass's sums: row ``q >> 1`` of ``both`` and, for half
    B (``q & 1``), of ``half_b``, ``q = lane_pix[l]``. A row's running sums stay in registers over its run of lanes
    (they come in row and half order), the same additions in the same order as one lane at a time
    (:func:`film_add`)."""
    lane = 0
    while lane < n:
        q = lane_pix[lane]
        r, is_b = q >> 1, (q & 1) != 0
        s0, s1, s2 = both[r, 0], both[r, 1], both[r, 2]
        b0, b1, b2 = half_b[r, 0], half_b[r, 1], half_b[r, 2]
        while lane < n and lane_pix[lane] == q:
            x0, x1, x2 = lane_vec(V, V_L, lane)
            s0 += x0
            s1 += x1
            s2 += x2
            b0 += x0
            b1 += x1
            b2 += x2
            lane += 1
        both[r, 0], both[r, 1], both[r, 2] = s0, s1, s2
        if is_b:
            half_b[r, 0], half_b[r, 1], half_b[r, 2] = b0, b1, b2


kernel_cache.restore()
