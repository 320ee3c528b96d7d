"""``EXT_meshopt_compression`` / ``KHR_meshopt_compression``: bufferViews compressed with meshoptimizer's codecs,
decoded here in pure Python and NumPy (no extra dependency), from the two extensions' specifications (Khronos glTF
repository, ``extensions/2.0/Vendor/EXT_meshopt_compression`` and ``extensions/2.0/Khronos/KHR_meshopt_compression``,
Appendix A "Bitstream" and Appendix B "Filters").

What a compressed bufferView becomes (:meth:`pyrt.io.assets.gltf_file.GltfFile.view_bytes`): its extension object
``{buffer, byteOffset, byteLength, byteStride, count, mode, filter}`` names the compressed bytes; they are decoded
to ``count * byteStride`` bytes that replace the view's own data (the view's ``buffer`` is then a fallback, or a
placeholder buffer without data: ``extensions.<name>.fallback = true``, never read). Accessors read the decoded
bytes as usual.

The modes and filters:

- ``ATTRIBUTES`` (:func:`decode_vertex_buffer`): the vertex codec, header ``0xA0`` (version 0, the only one
  ``EXT_meshopt_compression`` defines) or ``0xA1`` (version 1, ``KHR_meshopt_compression``: per-block control
  modes and per-channel 16-bit / XOR delta modes). Elements are split in blocks of up to 256; each byte position
  of a block is a "data block" of groups of 16 zigzag deltas packed in 0/1/2/4/8 bits with sentinels for the
  values that do not fit; the deltas chain from the baseline element in the tail. Vectorised: Python walks the
  group headers to find where each group starts (one step per 16 bytes of output), NumPy unpacks the groups and
  accumulates the deltas;
- ``TRIANGLES`` (:func:`decode_index_buffer`): the triangle codec (headers ``0xE0`` / ``0xE1``): an edge FIFO and
  a vertex FIFO, one code byte per triangle. Sequential by nature: a Python loop per triangle (about a
  million triangles a second on one core);
- ``INDICES`` (:func:`decode_index_sequence`): the index sequence codec (``0xD0`` / ``0xD1``): LEB128 zigzag
  deltas against one of two baselines; vectorised;
- filters (:func:`apply_filter`, after ``ATTRIBUTES`` only): ``NONE``, ``OCTAHEDRAL`` (unit vectors as 8/16-bit
  snorm), ``QUATERNION`` (16-bit snorm), ``EXPONENTIAL`` (float32 from 8-bit exponent + 24-bit mantissa, exact),
  and ``COLOR`` (``KHR_meshopt_compression`` only: YCoCg to 8/16-bit unorm RGBA). The octahedral, quaternion and
  colour filters compute in float32 as the specification's pseudo-code does; it allows one unit in the last place
  of the output integers, which is the bound to hold them to against another decoder.

As the reference decoder, both vertex codec versions and both triangle codec versions are accepted under either
extension name. A malformed stream (wrong header, a stream that ends early or has bytes left over, an invalid
channel mode, a FIFO entry read before it was written, parameters the extension forbids) raises
:class:`MeshoptError`, which :class:`GltfFile` turns into an :class:`AssetError` naming the file and the bufferView.
"""
from __future__ import annotations

import numpy as np

from pyrt.io.assets.common import AssetError

EXT_MESHOPT = "EXT_meshopt_compression"
KHR_MESHOPT = "KHR_meshopt_compression"
#: the two extension names (the KHR one is the ratified successor: vertex codec version 1, the COLOR filter)
MESHOPT_EXTENSIONS = (EXT_MESHOPT, KHR_MESHOPT)
MODES = ("ATTRIBUTES", "TRIANGLES", "INDICES")
FILTERS = ("NONE", "OCTAHEDRAL", "QUATERNION", "EXPONENTIAL", "COLOR")


class MeshoptError(AssetError):
    """A compressed stream or extension object this decoder cannot decode (the message says why; it names neither
    the file nor the bufferView: :class:`GltfFile` re-raises it as an :class:`AssetError` that does)."""


def meshopt_extension(obj):
    """``(name, extension object)`` of the meshopt extension of a bufferView or buffer dict, or ``(None, None)``."""
    ext = obj.get("extensions") if isinstance(obj, dict) else None
    if isinstance(ext, dict):
        for name in MESHOPT_EXTENSIONS:
            if name in ext:
                return name, ext[name]
    return None, None


def is_fallback_buffer(buf):
    """True for a buffer marked ``extensions.<meshopt>.fallback = true``: only compressed views refer to it."""
    _, ext = meshopt_extension(buf)
    return isinstance(ext, dict) and ext.get("fallback") is True


def check_params(name, count, stride, mode, filt):
    """The rules of the extension object (the specification's "For the extension object to be valid" list).

    Raises
    ------
    MeshoptError
        For an unknown mode or filter, or a ``byteStride`` / ``count`` the mode or filter does not allow.
    """
    if mode not in MODES:
        raise MeshoptError(f"mode {mode!r} is not one of {', '.join(MODES)}")
    allowed = FILTERS if name == KHR_MESHOPT else FILTERS[:4]
    if filt not in allowed:
        raise MeshoptError(f"filter {filt!r} is not one of {', '.join(allowed)} ({name})")
    if mode == "ATTRIBUTES":
        if stride % 4 or not 4 <= stride <= 256:
            raise MeshoptError(f"mode ATTRIBUTES needs a byteStride divisible by 4 in 4..256, got {stride}")
    else:
        if stride not in (2, 4):
            raise MeshoptError(f"mode {mode} needs a byteStride of 2 or 4, got {stride}")
        if filt != "NONE":
            raise MeshoptError(f"mode {mode} allows no filter, got {filt}")
        if mode == "TRIANGLES" and count % 3:
            raise MeshoptError(f"mode TRIANGLES needs a count divisible by 3, got {count}")
    need = {"OCTAHEDRAL": (4, 8), "QUATERNION": (8,), "COLOR": (4, 8)}.get(filt)
    if need is not None and stride not in need:
        raise MeshoptError(f"filter {filt} needs a byteStride of {' or '.join(map(str, need))}, got {stride}")


def decode(data, count, stride, mode, filt="NONE", name=EXT_MESHOPT):
    """The ``count * stride`` bytes a compressed bufferView decodes to.

    Parameters
    ----------
    data : bytes-like
        The compressed stream (exactly the extension's ``byteLength`` bytes: the codecs find their tail from the
        end).
    count, stride : int
        The extension's ``count`` and ``byteStride``.
    mode, filt : str
        The extension's ``mode`` and ``filter``.
    name : str
        :data:`EXT_MESHOPT` or :data:`KHR_MESHOPT` (the COLOR filter is KHR's only).

    Raises
    ------
    MeshoptError
        Invalid parameters (:func:`check_params`) or a malformed stream.
    """
    check_params(name, count, stride, mode, filt)
    if mode == "ATTRIBUTES":
        out = decode_vertex_buffer(data, count, stride)
        return apply_filter(out, count, stride, filt) if filt != "NONE" else out
    if mode == "TRIANGLES":
        idx = decode_index_buffer(data, count)
    else:
        idx = decode_index_sequence(data, count)
    return idx.astype("<u4" if stride == 4 else "<u2").tobytes()    # 16-bit output wraps, as specified


# ---------------------------------------------------------------------------------------------------------------
# mode ATTRIBUTES: the vertex codec

#: the bit widths a group's 2-bit header selects: version 0, and version 1 under control modes 0 and 1
_BITS_V0 = (0, 2, 4, 8)
_BITS_V1 = ((0, 1, 2, 4), (1, 2, 4, 8))


def _sentinel_table(bits):
    """bytes.translate table: for each byte value, how many of its ``bits``-bit fields are the sentinel (all 1)."""
    sentinel, per = (1 << bits) - 1, 8 // bits
    return bytes(sum(((v >> (bits * j)) & sentinel) == sentinel for j in range(per)) for v in range(256))


_SENTINELS = {b: _sentinel_table(b) for b in (1, 2, 4)}


def _unpack_groups(buf, offsets, bits):
    """The (N, 16) uint8 values of N groups of ``bits``-bit deltas (1, 2 or 4) starting at ``offsets`` of ``buf``
    (uint8 array): the packed fields (1-bit: least significant bit first; 2 and 4-bit: most significant first),
    each sentinel replaced by the next of the full bytes that follow the packed part."""
    nfixed = 2 * bits
    offsets = np.asarray(offsets, dtype=np.int64)
    packed = buf[offsets[:, None] + np.arange(nfixed)]                       # (N, nfixed)
    per = 8 // bits
    if bits == 1:
        shifts = np.arange(per)
    else:
        shifts = bits * np.arange(per - 1, -1, -1)
    codes = ((packed[:, :, None] >> shifts.astype(np.uint8)) & ((1 << bits) - 1)).reshape(len(offsets), 16)
    sentinel = codes == (1 << bits) - 1
    if not sentinel.any():
        return codes.astype(np.uint8)
    extra = offsets[:, None] + nfixed + np.cumsum(sentinel, axis=1) - 1
    return np.where(sentinel, buf[np.where(sentinel, extra, 0)], codes).astype(np.uint8)


def decode_vertex_buffer(data, count, stride):
    """Decode an ``ATTRIBUTES`` stream (vertex codec version 0 or 1) to ``count * stride`` bytes.

    Raises
    ------
    MeshoptError
        A header other than 0xA0 / 0xA1, a stream too short for its tail or that ends before its blocks do, bytes
        left between the last block and the tail, an invalid channel mode.
    """
    data = bytes(data)
    n = len(data)
    if count == 0:
        if n < 1 or data[0] not in (0xA0, 0xA1):
            raise MeshoptError("ATTRIBUTES stream: missing header 0xA0/0xA1")
        return b""
    if n < 1 + stride:
        raise MeshoptError(f"ATTRIBUTES stream of {n} bytes is too short for one {stride}-byte element")
    if data[0] & 0xF0 != 0xA0 or data[0] & 0x0F > 1:
        raise MeshoptError(f"ATTRIBUTES stream header 0x{data[0]:02X}, expected 0xA0 or 0xA1")
    version = data[0] & 0x0F
    tail_size = stride + (stride // 4 if version else 0)
    tail_pad = max(tail_size, 24 if version else 32)
    if n - 1 < tail_pad:
        raise MeshoptError(f"ATTRIBUTES stream of {n} bytes is shorter than its {tail_pad}-byte tail")
    end = n - tail_pad                       # the blocks end here; the (padded) tail follows
    tail = data[n - tail_size:]
    base = np.frombuffer(tail, dtype=np.uint8, count=stride)
    channels = tail[stride:] if version else bytes(stride // 4)
    for c, ch in enumerate(channels):
        if (ch & 15) > 2 or ((ch & 15) < 2 and ch >> 4):
            raise MeshoptError(f"ATTRIBUTES stream: invalid channel mode 0x{ch:02X} for bytes {4 * c}..{4 * c + 3}")

    buf = np.frombuffer(data, dtype=np.uint8)
    counts = {b: data.translate(_SENTINELS[b]) for b in (1, 2, 4)}
    block_max = min((8192 // stride) & ~15, 256)
    groups = {1: [], 2: [], 4: [], 8: []}    # bits -> [(stream offset, byte position k, padded column)]
    literals = []                            # (stream offset, k, column, length)
    valid = []                               # (padded column of the block, its element count)
    pos, col, left = 1, 0, count
    while left:
        bc = min(left, block_max)
        aligned = (bc + 15) & ~15
        ngroups = aligned // 16
        hsize = (ngroups + 3) // 4
        control = b""
        if version:
            control = data[pos: pos + stride // 4]
            pos += stride // 4
            if pos > end:
                raise MeshoptError("ATTRIBUTES stream ends inside a block's control header")
        for k in range(stride):
            ctrl = (control[k >> 2] >> ((k & 3) * 2)) & 3 if version else 0
            if ctrl == 3:                    # literal: the block's delta bytes as they are
                if pos + bc > end:
                    raise MeshoptError("ATTRIBUTES stream ends inside a literal data block")
                literals.append((pos, k, col, bc))
                pos += bc
                continue
            if ctrl == 2:                    # all deltas 0: nothing stored
                continue
            table = _BITS_V1[ctrl] if version else _BITS_V0
            header = data[pos: pos + hsize]
            pos += hsize
            if pos > end:
                raise MeshoptError("ATTRIBUTES stream ends inside a data block header")
            for g in range(ngroups):
                bits = table[(header[g >> 2] >> ((g & 3) * 2)) & 3]
                if bits == 0:
                    continue
                if bits == 8:
                    size = 16
                else:
                    nf = 2 * bits
                    size = nf + sum(counts[bits][pos: pos + nf])
                groups[bits].append((pos, k, col + 16 * g))
                pos += size
                if pos > end:
                    raise MeshoptError("ATTRIBUTES stream ends inside a group of deltas")
        valid.append((col, bc))
        col += aligned
        left -= bc
    if pos != end:
        raise MeshoptError(f"ATTRIBUTES stream has {end - pos} bytes left between its blocks and its tail")

    deltas = np.zeros((stride, col), dtype=np.uint8)          # zigzag deltas, per byte position, padded blocks
    lane = np.arange(16)
    for bits, lst in groups.items():
        if not lst:
            continue
        g = np.asarray(lst, dtype=np.int64)
        if bits == 8:
            vals = buf[g[:, 0:1] + lane]
        else:
            vals = _unpack_groups(buf, g[:, 0], bits)
        deltas[g[:, 1:2], g[:, 2:3] + lane] = vals
    for off, k, c, length in literals:
        deltas[k, c: c + length] = buf[off: off + length]
    cols = np.concatenate([np.arange(c, c + bc) for c, bc in valid])
    d = np.ascontiguousarray(deltas[:, cols].T)                   # (count, stride)

    out = np.empty((count, stride), dtype=np.uint8)
    for c, ch in enumerate(channels):
        s = slice(4 * c, 4 * c + 4)
        mode = ch & 15
        if mode == 0:                    # byte deltas, zigzag
            dd = d[:, s]
            v = (dd >> 1) ^ ((dd & 1) * np.uint8(255))
            out[:, s] = np.add.accumulate(v, axis=0, dtype=np.uint8) + base[s]
        elif mode == 1:                  # 16-bit deltas, zigzag, little-endian
            w = np.ascontiguousarray(d[:, s]).view("<u2")
            v = (w >> 1) ^ ((w & 1) * np.uint16(0xFFFF))
            b16 = base[s].copy().view("<u2")
            out[:, s] = (np.add.accumulate(v, axis=0, dtype=np.uint16) + b16).astype("<u2").view(np.uint8)
        else:                            # 32-bit XOR deltas, rotated left by (32 - r) & 31 on decoding
            w = np.ascontiguousarray(d[:, s]).view("<u4")[:, 0]
            r = (32 - (ch >> 4)) & 31
            w = (w << np.uint32(r)) | (w >> np.uint32((32 - r) & 31)) if r else w
            b32 = base[s].copy().view("<u4")[0]
            out[:, s] = (np.bitwise_xor.accumulate(w) ^ b32).astype("<u4").view(np.uint8).reshape(count, 4)
    return out.tobytes()


# ---------------------------------------------------------------------------------------------------------------
# mode TRIANGLES: the triangle codec

def decode_index_buffer(data, count):
    """Decode a ``TRIANGLES`` stream (header 0xE0 or 0xE1) to ``count`` indices (int64, 3 per triangle).

    Raises
    ------
    MeshoptError
        A wrong header, a stream too short or with bytes left over, a malformed varint, a FIFO entry read before it
        was written.
    """
    data = bytes(data)
    n = len(data)
    ntri = count // 3
    if n < 1 + ntri + 16:
        raise MeshoptError(f"TRIANGLES stream of {n} bytes is too short for {ntri} triangles (at least "
                           f"{1 + ntri + 16})")
    if data[0] & 0xF0 != 0xE0 or data[0] & 0x0F > 1:
        raise MeshoptError(f"TRIANGLES stream header 0x{data[0]:02X}, expected 0xE0 or 0xE1")
    fecmax = 13 if data[0] & 0x0F else 15     # version 1: codes 0xXd / 0xXe are last -/+ 1
    safe_end = n - 16
    aux = data[safe_end:]
    M = 0xFFFFFFFF
    ea, eb = [None] * 16, [None] * 16        # edge FIFO; None: never written (reading it is an error)
    vf = [None] * 16                          # vertex FIFO
    eo = vo = 0
    nxt = last = 0
    dp = 1 + ntri
    out = [0] * (3 * ntri)

    def varint():
        nonlocal dp
        v = shift = 0
        for _ in range(5):
            b = data[dp]
            dp += 1
            v |= (b & 127) << shift
            if b < 128:
                return v & M
            shift += 7
        raise MeshoptError(f"TRIANGLES stream: varint longer than 5 bytes at byte {dp - 5}")

    def index(v):                             # zigzag delta from last
        nonlocal last
        last = (last + ((v >> 1) ^ -(v & 1))) & M
        return last

    try:
        for t in range(ntri):
            if dp > safe_end:
                raise MeshoptError("TRIANGLES stream: the extra data runs into the 16-byte tail")
            code = data[1 + t]
            if code < 0xF0:
                e = (eo - 1 - (code >> 4)) & 15
                a, b = ea[e], eb[e]
                fec = code & 15
                if fec < fecmax:
                    if fec == 0:
                        c = nxt
                        nxt = (nxt + 1) & M
                        vf[vo] = c
                        vo = (vo + 1) & 15
                    else:
                        c = vf[(vo - 1 - fec) & 15]
                else:
                    if fec == 15:
                        c = index(varint())
                    else:                     # 13: last - 1, 14: last + 1
                        c = last = (last + (fec - (fec ^ 3))) & M
                    vf[vo] = c
                    vo = (vo + 1) & 15
                ea[eo], eb[eo] = c, b
                eo = (eo + 1) & 15
                ea[eo], eb[eo] = a, c
                eo = (eo + 1) & 15
            else:
                if code < 0xFE:
                    aux_byte = aux[code & 15]
                    a = nxt
                    nxt = (nxt + 1) & M
                    fea = 0
                else:
                    aux_byte = data[dp]
                    dp += 1
                    if aux_byte == 0:
                        nxt = 0
                    fea = 0 if code == 0xFE else 15
                    a = 0
                    if fea == 0:
                        a = nxt
                        nxt = (nxt + 1) & M
                feb, fec = aux_byte >> 4, aux_byte & 15
                if code < 0xFE and (feb == 15 or fec == 15):
                    raise MeshoptError(f"TRIANGLES stream: its code table entry 0x{aux_byte:02X} has a nibble "
                                       "0xF (the specification forbids it)")
                if feb == 0:
                    b = nxt
                    nxt = (nxt + 1) & M
                elif feb < 15:
                    b = vf[(vo - feb) & 15]
                if fec == 0:
                    c = nxt
                    nxt = (nxt + 1) & M
                elif fec < 15:
                    c = vf[(vo - fec) & 15]
                if fea == 15:
                    a = index(varint())
                if feb == 15:
                    b = index(varint())
                if fec == 15:
                    c = index(varint())
                vf[vo] = a
                vo = (vo + 1) & 15
                if feb == 0 or feb == 15:
                    vf[vo] = b
                    vo = (vo + 1) & 15
                if fec == 0 or fec == 15:
                    vf[vo] = c
                    vo = (vo + 1) & 15
                ea[eo], eb[eo] = b, a
                eo = (eo + 1) & 15
                ea[eo], eb[eo] = c, b
                eo = (eo + 1) & 15
                ea[eo], eb[eo] = a, c
                eo = (eo + 1) & 15
            out[3 * t] = a
            out[3 * t + 1] = b
            out[3 * t + 2] = c
    except IndexError:
        raise MeshoptError("TRIANGLES stream ends early") from None
    if dp != safe_end:
        raise MeshoptError(f"TRIANGLES stream: {safe_end - dp} bytes of extra data left before the 16-byte tail")
    try:
        return np.array(out, dtype=np.int64)
    except TypeError:
        raise MeshoptError("TRIANGLES stream reads an edge or vertex FIFO entry that was never written") from None


# ---------------------------------------------------------------------------------------------------------------
# mode INDICES: the index sequence codec

def decode_index_sequence(data, count):
    """Decode an ``INDICES`` stream (header 0xD0 or 0xD1) to ``count`` indices (int64). Vectorised: the varint
    ends are the bytes below 128, each value is the sum of its 7-bit groups, and each of the two baselines is a
    running sum of the deltas that use it.

    Raises
    ------
    MeshoptError
        A wrong header, a stream whose varints are not exactly ``count`` before the 4-byte tail, a varint longer
        than 5 bytes.
    """
    data = bytes(data)
    n = len(data)
    if n < 5:
        raise MeshoptError(f"INDICES stream of {n} bytes is shorter than its header and 4-byte tail")
    if data[0] & 0xF0 != 0xD0 or data[0] & 0x0F > 1:
        raise MeshoptError(f"INDICES stream header 0x{data[0]:02X}, expected 0xD0 or 0xD1")
    body = np.frombuffer(data, dtype=np.uint8, count=n - 5, offset=1)
    ends = np.flatnonzero(body < 128)
    if len(ends) < count:
        raise MeshoptError(f"INDICES stream ends early: {len(ends)} of {count} indices")
    stop = int(ends[count - 1]) + 1 if count else 0
    if stop != len(body):
        raise MeshoptError(f"INDICES stream: {len(body) - stop} bytes left before the 4-byte tail")
    if count == 0:
        return np.zeros(0, dtype=np.int64)
    ends = ends[:count]
    starts = np.concatenate(([0], ends[:-1] + 1))
    if np.any(ends - starts >= 5):
        raise MeshoptError("INDICES stream: varint longer than 5 bytes")
    within = np.arange(len(body)) - np.repeat(starts, ends - starts + 1)
    groups = (body.astype(np.uint64) & 127) << (7 * within).astype(np.uint64)
    v = (np.add.reduceat(groups, starts) & 0xFFFFFFFF).astype(np.uint32)
    which = (v & 1).astype(bool)
    v = v >> 1
    delta = (v >> 1) ^ (np.uint32(0) - (v & 1))
    out = np.empty(count, dtype=np.uint32)
    for baseline in (False, True):
        m = which == baseline
        out[m] = np.add.accumulate(delta[m], dtype=np.uint32)
    return out.astype(np.int64)


# ---------------------------------------------------------------------------------------------------------------
# filters (Appendix B), applied to the decoded ATTRIBUTES bytes

def _round_away(x):
    """Round half away from zero (the specification's ``round``)."""
    return np.where(x >= 0, np.floor(x + np.float32(0.5)), np.ceil(x - np.float32(0.5)))


def apply_filter(raw, count, stride, filt):
    """The bytes of ``count`` decoded ``stride``-byte elements after filter ``filt`` (a name of :data:`FILTERS`).

    Element layouts (little-endian): OCTAHEDRAL and COLOR four int8 (stride 4) or int16 (stride 8) components;
    QUATERNION four int16; EXPONENTIAL int32 words.
    """
    if filt == "NONE" or count == 0:
        return raw
    with np.errstate(all="ignore"):       # invalid input is unspecified by the extension: no warning, no crash
        if filt == "EXPONENTIAL":
            v = np.frombuffer(raw, dtype="<i4")
            e = np.clip(v >> 24, -126, 127)
            m = (v << 8) >> 8
            return np.ldexp(m.astype(np.float64), e).astype("<f4").tobytes()
        small = stride == 4
        it = np.dtype("<i1" if small else "<i2")
        x = np.frombuffer(raw, dtype=it).reshape(count, 4).astype(np.float32)
        if filt == "OCTAHEDRAL":
            top = np.float32(127.0 if small else 32767.0)
            one = x[:, 2]
            one = np.where(one == 0, np.float32(1), one)
            px, py = x[:, 0] / one, x[:, 1] / one
            pz = np.float32(1) - np.abs(px) - np.abs(py)
            t = np.minimum(pz, np.float32(0))
            px = px - np.copysign(t, px)
            py = py - np.copysign(t, py)
            ln = np.sqrt(px * px + py * py + pz * pz)
            res = np.stack([px / ln, py / ln, pz / ln], axis=1) * top
            out = np.empty((count, 4), dtype=it)
            out[:, :3] = np.clip(np.nan_to_num(_round_away(res)), -top, top)
            out[:, 3] = np.frombuffer(raw, dtype=it).reshape(count, 4)[:, 3]
            return out.tobytes()
        if filt == "QUATERNION":
            q = np.frombuffer(raw, dtype="<i2").reshape(count, 4)
            one = (q[:, 3] | 3).astype(np.float32)
            rng = np.float32(1.0 / np.sqrt(2.0))
            xyz = q[:, :3].astype(np.float32) / one[:, None] * rng
            w = np.sqrt(np.maximum(np.float32(0), np.float32(1) - np.sum(xyz * xyz, axis=1, dtype=np.float32)))
            mc = (q[:, 3] & 3).astype(np.int64)
            out = np.empty((count, 4), dtype="<i2")
            rows = np.arange(count)
            vals = np.clip(_round_away(np.column_stack([w, xyz]) * np.float32(32767)), -32767, 32767)
            for j in range(4):           # component j goes to (maxcomp + j) % 4: w first, then x, y, z
                out[rows, (mc + j) % 4] = vals[:, j]
            return out.tobytes()
        if filt == "COLOR":
            ut = np.dtype("<u1" if small else "<u2")
            u = np.frombuffer(raw, dtype=ut).reshape(count, 4).astype(np.int64)
            s = np.frombuffer(raw, dtype=it).reshape(count, 4).astype(np.int64)
            a_in = u[:, 3]
            msb = np.zeros(count, dtype=np.int64)
            nz = a_in > 0
            msb[nz] = np.floor(np.log2(a_in[nz])).astype(np.int64)
            scale = (1 << (msb + 1)) - 1
            y, co, cg = u[:, 0], s[:, 1], s[:, 2]
            rgb = np.stack([y + co - cg, y + cg, y - co - cg], axis=1)
            a = a_in & (scale >> 1)
            a = (a << 1) | (a & 1)
            top = 255 if small else 65535
            ss = np.float32(top) / scale.astype(np.float32)
            vals = np.column_stack([rgb, a]).astype(np.float32) * ss[:, None]
            return np.clip(_round_away(vals), 0, top).astype(ut).tobytes()
    raise MeshoptError(f"unknown filter {filt!r}")
