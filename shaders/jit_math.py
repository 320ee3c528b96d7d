"""Elementary functions for the compiled kernels that vectorise: sine and cosine, arctangent, arc cosine.

A loop that calls libm (``math.sin``, ``math.atan2``, ``math.acos``) stays scalar: LLVM vectorises no libm call in
Numba's code. These are straight-line arithmetic (Cody-Waite range reduction and Cephes' minimax polynomials, the
quadrants applied by selects), so a packet stage that uses them vectorises, and the same arithmetic runs scalar or
vectorised: a lane's values are the same bits in either. Accuracy (float64, tests/test_jit_math.py against NumPy on
random and edge inputs): :func:`sincos` within 3.4e-16 absolute for ``|x|`` up to a few hundred, :func:`atan2` within
2 ulp of the result's magnitude (pi / 2 for a quarter turn), :func:`acos` within 4e-16 absolute.

Every function is ``numba.extending.register_jitable`` (callable from nopython code and from plain Python).
"""
from __future__ import annotations

import math

from numba.extending import register_jitable

#: Cephes' ``atan`` reduction points and its extra bits of pi/2
_T3P8 = 2.41421356237309504880      # tan(3 pi / 8)
_MOREBITS = 6.123233995736765886130e-17


@register_jitable
def sincos(x):
    """``(sin x, cos x)`` for ``|x|`` up to a few hundred, within 3e-16 of libm's: Cody-Waite reduction by pi/2 to
    [-pi/4, pi/4] (three parts of pi/2) and Cephes' minimax polynomials, the quadrant applied arithmetically."""
    j = math.floor(x * 0.6366197723675814 + 0.5)
    r = ((x - j * 1.5707963267341256) - j * 6.077100506303966e-11) - j * 2.0222662487959506e-21
    z = r * r
    s = r + r * z * (-1.66666666666666307295e-1 + z * (8.33333333332211858878e-3 + z * (
        -1.98412698295895385996e-4 + z * (2.75573136213857245213e-6 + z * (-2.50507477628578072866e-8
                                                                           + z * 1.58962301576546568060e-10)))))
    c = 1.0 - 0.5 * z + z * z * (4.16666666666665929218e-2 + z * (-1.38888888888730564116e-3 + z * (
        2.48015872888517045348e-5 + z * (-2.75573141792967388112e-7 + z * (2.08757008419747316778e-9
                                                                          + z * -1.13585365213876817300e-11)))))
    q = j - 4.0 * math.floor(j * 0.25)                 # the quadrant, 0..3
    odd = q - 2.0 * math.floor(q * 0.5)                # 1 in quadrants 1 and 3: sine and cosine swap
    sn, cs = s + odd * (c - s), c + odd * (s - c)
    s_sign = 1.0 - 2.0 * math.floor(q * 0.5)                                    # quadrants 2, 3
    c_sign = 1.0 - 2.0 * (math.floor((q + 1.0) * 0.5) - 2.0 * math.floor((q + 1.0) * 0.25))   # quadrants 1, 2
    return s_sign * sn, c_sign * cs


@register_jitable
def atan_pos(x):
    """``atan(x)`` for ``x >= 0`` (``inf`` included: pi / 2): Cephes' ``atan`` (the argument reduced to
    ``|x| <= 0.66`` by ``-1 / x`` above tan(3 pi / 8) or ``(x - 1) / (x + 1)`` above 0.66, a rational minimax
    approximation of degree 4 / 5), every branch computed and one selected."""
    big = x > _T3P8
    mid = (x > 0.66) & ~big
    xb = -1.0 / (x if big else 1.0)
    xm = (x - 1.0) / (x + 1.0)
    t = xb if big else (xm if mid else x)
    y0 = (math.pi / 2) if big else ((math.pi / 4) if mid else 0.0)
    z = t * t
    p = (((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z - 7.500855792314704667340e1) * z
         - 1.228866684490136173410e2) * z - 6.485021904942025371773e1
    q = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z + 4.328810604912902668951e2) * z
         + 4.853903996359136964868e2) * z + 1.945506571482613964425e2
    r = t * (z * p / q) + t
    r = r + (_MOREBITS if big else (0.5 * _MOREBITS if mid else 0.0))
    return y0 + r


@register_jitable
def atan2(y, x):
    """``atan2(y, x)`` in [-pi, pi] with libm's quadrants and signed zeros (``atan2(+-0, -0)`` is +-pi, ``atan2(+-0,
    +0)`` is +-0: a lat-long map's pole ``(0, 1, 0)`` looks up column ``u = 1/2``, as NumPy's), by :func:`atan_pos`
    of ``|y| / |x|``."""
    ax, ay = abs(x), abs(y)
    both = (ax == 0.0) & (ay == 0.0)
    ratio = ay / (ax if ax > 0.0 else 1.0)
    a = atan_pos(ratio if ax > 0.0 else math.inf)
    a = 0.0 if both else a
    a = (math.pi - a) if math.copysign(1.0, x) < 0.0 else a
    return math.copysign(a, y)


@register_jitable
def acos(x):
    """``acos(x)`` for ``x`` in [-1, 1] (clamped): ``atan2(sqrt((1 - x)(1 + x)), x)`` (the factors exact near +-1)."""
    x = min(max(x, -1.0), 1.0)
    return atan2(math.sqrt((1.0 - x) * (1.0 + x)), x)
