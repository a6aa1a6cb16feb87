"""cos, sin and tan as the compiled residual tapes compute them (fdi/kernels.c ``vtrig``; numba
compiles :func:`_trig` itself as ``fdi._jit._vtrig``): one statement of the operations, so the C and
numba paths give the same bits.

libm's cos, sin and tan are a call per sample, so the tapes' loops over samples did not vectorise:
the CyCab's ARR2 and ARR3 take a cosine and a tangent of the corrected steering angle on every
sample of every individual that corrects it (7 % of a diagnosis). These are FreeBSD's msun (Sun's
fdlibm with Bruce Evans' kernels) with their branches as selects:

- x = n pi/2 + (y0 + y1): n by the 1.5 * 2^52 shift (round half to even), pi/2 in three parts of
  33 bits and a tail (Cody & Waite: the products are exact for |n| < 2^20), the first two and the
  third subtracted each by a two-sum, so that the remainder keeps its bits when x lies within 2^-54
  of a multiple of pi/2 (fdlibm's rounds taken all at once lose the second's error term: 1e-16
  relative errors; one sum of the last two parts, 1.8 ulp in tan near the closest such x);
- ``__kernel_cos`` and ``__kernel_sin`` (degree 14 and 13 on [-pi/4, pi/4], the tail y1 taken in),
  picked and signed by n mod 4;
- ``__kernel_tan`` (degree 27; past 0.6744 through tan(pi/4 - x); for odd n, -1/tan computed with a
  correction step, its splits by Veltkamp's 26 bits where fdlibm clears the low word).

Within 0.8 ulp of the exact value (0.75 the worst found; tests/test_kernels.py, against mpmath,
the arguments closest to multiples of pi/2 below 2^20 among them). Beyond |x| = 1.5 * 2^20, and for
inf and NaN, the platform's libm (:mod:`math`), as before. The numpy path keeps numpy's own
functions: the paths differ in the last bit, as they did with libm (costs compared to 1e-9).

>>> import math
>>> _trig(0.5, 0) == math.cos(0.5), _trig(-0.0, 2), _trig(1e300, 1) == math.sin(1e300)
(True, -0.0, True)
"""
from __future__ import annotations

import math

LIMIT = 1572864.0                      # 1.5 * 2^20: |n| < 2^20 below it (exact products with the parts)
_SHIFT = 6755399441055744.0            # 1.5 * 2^52
_INVPIO2 = float.fromhex("0x1.45f306dc9c883p-1")
_PIO2_1 = float.fromhex("0x1.921fb54400000p+0")
_PIO2_2 = float.fromhex("0x1.0b4611a600000p-34")
_PIO2_3 = float.fromhex("0x1.3198a2e000000p-69")
_PIO2_3T = float.fromhex("0x1.b839a252049c1p-104")
_C1, _C2, _C3, _C4, _C5, _C6 = (float.fromhex(h) for h in (
    "0x1.555555555554cp-5", "-0x1.6c16c16c15177p-10", "0x1.a01a019cb1590p-16", "-0x1.27e4f809c52adp-22",
    "0x1.1ee9ebdb4b1c4p-29", "-0x1.8fae9be8838d4p-37"))
_S1, _S2, _S3, _S4, _S5, _S6 = (float.fromhex(h) for h in (
    "-0x1.5555555555549p-3", "0x1.111111110f8a6p-7", "-0x1.a01a019c161d5p-13", "0x1.71de357b1fe7dp-19",
    "-0x1.ae5e68a2b9cebp-26", "0x1.5d93a5acfd57cp-33"))
_T0, _T1, _T2, _T3, _T4, _T5, _T6, _T7, _T8, _T9, _T10, _T11, _T12 = (float.fromhex(h) for h in (
    "0x1.5555555555563p-2", "0x1.111111110fe7ap-3", "0x1.ba1ba1bb341fep-5", "0x1.664f48406d637p-6",
    "0x1.226e3e96e8493p-7", "0x1.d6d22c9560328p-9", "0x1.7dbc8fee08315p-10", "0x1.344d8f2f26501p-11",
    "0x1.026f71a8d1068p-12", "0x1.47e88a03792a6p-14", "0x1.2b80f32f0a7e9p-14", "-0x1.375cbdb605373p-16",
    "0x1.b2a7074bf7ad4p-16"))
_PIO4 = float.fromhex("0x1.921fb54442d18p-1")
_PIO4LO = float.fromhex("0x1.1a62633145c07p-55")
_TAN_FOLD = float.fromhex("0x1.59428p-1")   # fdlibm's 0.6744: high word 0x3fe59428
_SPLIT = 134217729.0                         # 2^27 + 1


def _trig(x: float, which: int) -> float:
    """cos (``which`` 0), sin (1) or tan (2) of ``x``: fdi/kernels.c vtrig's operations in their order."""
    if not abs(x) < LIMIT:
        if not math.isfinite(x):
            return x - x
        return math.cos(x) if which == 0 else (math.sin(x) if which == 1 else math.tan(x))
    if x == 0.0 and which != 0:         # sin and tan keep the sign of zero (the reduction loses it)
        return x
    fn = x * _INVPIO2 + _SHIFT
    fn = fn - _SHIFT
    q = int(fn) & 3
    r = x - fn * _PIO2_1
    s = fn * _PIO2_2
    h = r - s
    e = h - r
    err = (r - (h - e)) + (-s - e)
    t = fn * _PIO2_3
    h2 = h - t
    e2 = h2 - h
    lo = (err + ((h - (h2 - e2)) + (-t - e2))) - fn * _PIO2_3T
    y0 = h2 + lo
    y1 = (h2 - y0) + lo
    if which == 2:
        big = abs(y0) >= _TAN_FOLD
        neg = y0 < 0
        xs = -y0 if neg else y0
        ys = -y1 if neg else y1
        xb = (_PIO4 - xs) + (_PIO4LO - ys)
        xx = xb if big else y0
        yy = 0.0 if big else y1
        z = xx * xx
        w = z * z
        r = _T1 + w * (_T3 + w * (_T5 + w * (_T7 + w * (_T9 + w * _T11))))
        v = z * (_T2 + w * (_T4 + w * (_T6 + w * (_T8 + w * (_T10 + w * _T12)))))
        s = z * xx
        r = (yy + z * (s * (r + v) + yy)) + s * _T0
        w = xx + r
        iy = -1.0 if q & 1 else 1.0
        if big:
            near = iy - 2.0 * (xx - (w * w / (w + iy) - r))
            return -near if neg else near
        if not q & 1:
            return w
        c = w * _SPLIT
        zh = c - (c - w)
        vv = r - (zh - xx)
        a = -1.0 / w
        c = a * _SPLIT
        th = c - (c - a)
        return th + a * ((1.0 + th * zh) + th * vv)
    z = y0 * y0
    w = z * z
    r = z * (_C1 + z * (_C2 + z * _C3)) + w * w * (_C4 + z * (_C5 + z * _C6))
    hz = 0.5 * z
    v = 1.0 - hz
    c = v + (((1.0 - v) - hz) + (z * r - y0 * y1))
    r = _S2 + z * (_S3 + z * _S4) + z * w * (_S5 + z * _S6)
    v = z * y0
    s = y0 - ((z * (0.5 * y1 - v * r) - y1) - v * _S1)
    if which == 1:
        q = (q + 3) & 3
    return c if q == 0 else (-s if q == 1 else (-c if q == 2 else s))
