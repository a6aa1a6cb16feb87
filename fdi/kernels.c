/* The identification objective's generic heavy parts in C99: fdi._jit's functions, line for line.
 *
 * Each function does the floating-point operations of its numba twin (fdi/_jit.py), in the same
 * order, on the same IEEE doubles, calling the same libm for the transcendental functions (but the
 * exponential of eqs. 16 and 18 and the tapes' cos, sin and tan: their own, below, and numba's the
 * same Python statements compiled): the numbers are the numba path's, and the numpy path's to
 * round-off (tests/test_kernels.py, 1e-9 relative). Built by optim.native with -O3 and -ffp-contract=off (no fused multiply-adds: they
 * would change the last bits) and no fast-math (it would reorder sums). Arrays are C-contiguous;
 * bool arrays are numpy's one byte per element. fdi/_native.py loads it with ctypes and gives it
 * fdi._jit's signatures. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef int64_t I;
typedef uint8_t B;

/* the tape's operations (fdi.tape) */
enum { LOADF = 0, LOADP = 1, LOADS = 2, CONST = 3,
       ADD = 10, SUB = 11, MUL = 12, DIV = 13, POW = 14, ATAN2 = 15,
       NEG = 20, ABS, SIGN, SQRT, SQUARE, RECIP, EXP, LOG, SIN, COS, TAN, ASIN, ACOS, ATAN, SINH, COSH, TANH,
       ASINH, ACOSH, ATANH };

#define PI 3.141592653589793     /* numpy's pi, the same double */
#define NCOEFFS 7       /* the decoded coefficients the kernel reads (fdi.fused.COEFFS) */
#define BRACKET_FROM 256
#define BRACKET_SAMPLE 256

static I imax(I a, I b) { return a > b ? a : b; }
static I imin(I a, I b) { return a < b ? a : b; }
/* Python's max(a, b) and min(a, b) on floats: the first unless the second compares greater (less) */
static double pmax(double a, double b) { return b > a ? b : a; }
static double pmin(double a, double b) { return b < a ? b : a; }

/* ------------------------------------------------------------------ eq. (19), RK4 and Hermite */

/* eq. (19)'s RK4 grids (fdi._jit._rk4_grid's operations, P and dP/dt at k + 1 points h apart, inf
 * and 0 once P is no longer finite) for `rows` rows (coefficients c5[r * cs], c6[r * cs],
 * c7[r * cs]; row r's grid and slope at grid + r * (k + 1), slope + r * (k + 1)): eight rows in the
 * lanes of one vector, each lane the scalar's operations in their order (the same bits); a grid
 * costs its steps' chain of dependent operations, so eight take about the time of one */
typedef double v8d __attribute__((vector_size(64)));

static void rk4_grids(double p0, const double *c5, const double *c6, const double *c7, I cs, I rows, double h,
                      I k, double *grid, double *slope)
{
    double h2 = h / 2, h6 = h / 6;
    I w = k + 1;
    for (I r0 = 0; r0 < rows; r0 += 8) {
        I nl = imin(8, rows - r0);
        v8d C5, C6, C7, p, v;
        for (I l = 0; l < 8; l++) {
            I r = r0 + imin(l, nl - 1);          /* spare lanes repeat the last row: computed, not stored */
            C5[l] = c5[r * cs]; C6[l] = c6[r * cs]; C7[l] = c7[r * cs];
            p[l] = p0; v[l] = 0.0;
        }
        for (I l = 0; l < nl; l++) { grid[(r0 + l) * w] = p0; slope[(r0 + l) * w] = 0.0; }
        for (I i = 1; i <= k; i++) {
            v8d k1p = v;
            v8d k1v = C5 * v * v + C6 * p + C7;
            v8d k2p = v + h2 * k1v;
            v8d q = p + h2 * k1p, u = v + h2 * k1v;
            v8d k2v = C5 * u * u + C6 * q + C7;
            v8d k3p = v + h2 * k2v;
            q = p + h2 * k2p; u = v + h2 * k2v;
            v8d k3v = C5 * u * u + C6 * q + C7;
            v8d k4p = v + h * k3v;
            q = p + h * k3p; u = v + h * k3v;
            v8d k4v = C5 * u * u + C6 * q + C7;
            p = p + h6 * (k1p + 2 * k2p + 2 * k3p + k4p);
            v = v + h6 * (k1v + 2 * k2v + 2 * k3v + k4v);
            for (I l = 0; l < nl; l++) {
                double pl = p[l];
                int ok = isfinite(pl);
                grid[(r0 + l) * w + i] = ok ? pl : INFINITY;
                slope[(r0 + l) * w + i] = ok ? v[l] : 0.0;
            }
        }
    }
}

/* P at tau by cubic Hermite interpolation on the grid (fdi._jit._hermite's operations, in their
 * order: the same bits), NaN for a NaN tau. Written for GCC to vectorise the loops that call it
 * (hermite_taus, hermite_row): an int64 index (a gather of the grid where the machine has one:
 * 1.7x on AVX-512 against the scalar loop), no branches, NaN and the infinite ends by selects */
static inline double hermite(double tau, double h, I k, double kd, const double *grid, const double *slope)
{
    double x = tau / h;
    x = x < 0 ? 0.0 : x;
    x = x > kd ? kd : x;
    I j = (I)(x != x ? 0.0 : x);             /* floor: x >= 0 here */
    j = j < k - 1 ? j : k - 1;
    double s = x - (double)j;
    double pa = grid[j], pb = grid[j + 1];
    double va = slope[j] * h, vb = slope[j + 1] * h;
    double s2 = s * s;
    double s3 = s * s * s;
    double p = (2 * s3 - 3 * s2 + 1) * pa + (s3 - 2 * s2 + s) * va + (-2 * s3 + 3 * s2) * pb + (s3 - s2) * vb;
    p = (fabs(pa) < INFINITY) & (fabs(pb) < INFINITY) ? p : INFINITY;
    p = x != x ? NAN : p;
    return p;
}

/* P at tau[i], i < n */
static void hermite_taus(const double *restrict tau, I n, double h, I k, const double *restrict grid,
                         const double *restrict slope, double *restrict out)
{
    double kd = (double)k;
    for (I i = 0; i < n; i++) out[i] = hermite(tau[i], h, k, kd, grid, slope);
}

/* eq. (19)'s profile on t[i], i < n: P at t[i] - onset from the onset on, `nominal` before it */
static void hermite_row(const double *restrict t, I n, double onset, double nominal, double h, I k,
                        const double *restrict grid, const double *restrict slope, double *restrict out)
{
    double kd = (double)k;
    for (I i = 0; i < n; i++) {
        double tau = t[i] - onset;
        double p = hermite(tau < 0 ? 0.0 : tau, h, k, kd, grid, slope);
        out[i] = t[i] >= onset ? p : nominal;
    }
}

/* fdi.profiles.STEPS19, MIN_STEPS19: eq. (19)'s grid has at most and at least this many intervals over the window */
#define STEPS19 1000
#define MIN_STEPS19 100
static I steps19(double span, double step)
{
    double q = span / step;                  /* a NaN (0/0) or a q at most MIN_STEPS19 takes the fewest: no */
    if (!(q > MIN_STEPS19)) return MIN_STEPS19;   /* conversion of a NaN or a huge value (undefined in C) */
    return q > STEPS19 ? STEPS19 : (I)ceil(q);
}

/* eq. (19)'s rows on a grid spanning ``span``, eight rows' grids at a time (scratch of 8 (k + 1) each),
 * read at tau[r] (tau non-NULL: rk4_19) or at max(t - t0[r], 0) with the nominal value before the
 * onset (incipient19) */
static int eq19_rows(const double *tau, const double *t, const double *t0, I pop, I n, double span, double p0,
                     const double *b5, const double *b6, const double *b7, double step, double *out)
{
    I k = steps19(span, step);
    double h = span > 0 ? span / k : step;
    double *grid = malloc(sizeof(double) * 8 * (k + 1)), *slope = malloc(sizeof(double) * 8 * (k + 1));
    if (!grid || !slope) { free(grid); free(slope); return -1; }
    for (I r0 = 0; r0 < pop; r0 += 8) {
        I nl = imin(8, pop - r0);
        rk4_grids(p0, b5 + r0, b6 + r0, b7 + r0, 1, nl, h, k, grid, slope);
        for (I l = 0; l < nl; l++) {
            I r = r0 + l;
            if (tau)
                hermite_taus(tau + r * n, n, h, k, grid + l * (k + 1), slope + l * (k + 1), out + r * n);
            else
                hermite_row(t, n, t0[r], p0, h, k, grid + l * (k + 1), slope + l * (k + 1), out + r * n);
        }
    }
    free(grid); free(slope);
    return 0;
}

/* rk4_19: tau (pop, n) -> out (pop, n), the grid spanning the largest tau */
int rk4_19(const double *tau, I pop, I n, double p0, const double *b5, const double *b6, const double *b7,
           double step, double *out)
{
    double span = 0.0;
    for (I r = 0; r < pop; r++)
        for (I j = 0; j < n; j++)
            if (tau[r * n + j] > span) span = tau[r * n + j];
    return eq19_rows(tau, NULL, NULL, pop, n, span, p0, b5, b6, b7, step, out);
}

/* eq. (19)'s profile of each row on the samples t: rk4_19 on tau = max(t - t0[r], 0) (the grid's
 * span the largest tau of all rows, as there), nominal before the onset (fdi.profiles.incipient's
 * np.where): the same numbers without the population's tau and select passes */
int incipient19(const double *t, I n, const double *t0, I pop, double p0, const double *b5, const double *b6,
                const double *b7, double step, double *out)
{
    double span = 0.0;
    for (I r = 0; r < pop; r++)
        for (I j = 0; j < n; j++) {
            double x = t[j] - t0[r];
            double tau = x < 0 ? 0.0 : x;
            if (tau > span) span = tau;
        }
    return eq19_rows(NULL, t, t0, pop, n, span, p0, b5, b6, b7, step, out);
}

/* ------------------------------------------------------------------ a translation's distances */

/* fdi.hints._distance: per row r of q (rows, n), the sum over i = first, ..., n - 1, in that order,
 * of |s(q[r, i]) - target[i]| with s(x) = 1 / x when inverse, else x: numpy's operations (its sum
 * over the samples' axis adds one sample after another), without the transposed copy and the
 * three passes over the population's profiles */
int distance_rows(const double *q, I rows, I n, const double *target, I first, I inverse, double *out)
{
    for (I r = 0; r < rows; r++) {
        const double *x = q + r * n;
        double acc = 0.0;
        if (inverse)
            for (I i = first; i < n; i++) acc += fabs(1.0 / x[i] - target[i]);
        else
            for (I i = first; i < n; i++) acc += fabs(x[i] - target[i]);
        out[r] = acc;
    }
    return 0;
}


/* ------------------------------------------------------------------ the weighted median */

static double select_w(double *x, double *w, I lo, I hi, double below, double half)
{
    for (;;) {
        double a = x[lo], b = x[(lo + hi - 1) / 2], c = x[hi - 1];
        double pivot = pmax(pmin(a, b), pmin(pmax(a, b), c));
        I lt = lo, i = lo, gt = hi;
        double wl = 0.0, we = 0.0;
        while (i < gt) {
            double xi = x[i];
            if (xi < pivot) {
                wl += w[i];
                x[i] = x[lt]; x[lt] = xi;
                double t = w[i]; w[i] = w[lt]; w[lt] = t;
                lt++; i++;
            } else if (xi > pivot) {
                gt--;
                x[i] = x[gt]; x[gt] = xi;
                double t = w[i]; w[i] = w[gt]; w[gt] = t;
            } else {
                we += w[i];
                i++;
            }
        }
        if (below + wl >= half && lt > lo)
            hi = lt;
        else if (below + wl + we >= half || gt == hi)
            return pivot;
        else {
            below += wl + we;
            lo = gt;
        }
    }
}

/* scratch: 2 * BRACKET_SAMPLE + 2 * m doubles */
static double median_w(double *x, double *w, I m, double *scratch)
{
    double total = 0.0;
    for (I j = 0; j < m; j++) total += w[j];
    if (!(total > 0)) return 0.0;
    double half = 0.5 * total;
    if (m >= BRACKET_FROM) {
        I s = imin(BRACKET_SAMPLE, (I)(4.0 * sqrt((double)m)));
        double delta = 1.5 / sqrt((double)s);
        I step = m / s;
        double *xs = scratch, *ws = scratch + BRACKET_SAMPLE;
        double sw = 0.0;
        for (I k = 0; k < s; k++) {
            xs[k] = x[k * step];
            ws[k] = w[k * step];
            sw += ws[k];
        }
        if (sw > 0) {
            double a = select_w(xs, ws, 0, s, 0.0, sw * (0.5 - delta));
            double b = select_w(xs, ws, 0, s, 0.0, sw * (0.5 + delta));
            double *xm = scratch + 2 * BRACKET_SAMPLE, *wm = xm + m;
            double below = 0.0, above = 0.0;
            I k = 0;
            for (I j = 0; j < m; j++) {
                double xj = x[j];
                if (xj < a) below += w[j];
                else if (xj > b) above += w[j];
                else { xm[k] = xj; wm[k] = w[j]; k++; }
            }
            if (below < half && total - above >= half && k > 0)
                return select_w(xm, wm, 0, k, below, half);
        }
    }
    return select_w(x, w, 0, m, 0.0, half);
}

int weighted_median(const double *points, const double *weights, I n, I m, double *out)
{
    double *x = malloc(sizeof(double) * (m + 1)), *w = malloc(sizeof(double) * (m + 1));
    double *scratch = malloc(sizeof(double) * (2 * BRACKET_SAMPLE + 2 * m + 2));
    if (!x || !w || !scratch) { free(x); free(w); free(scratch); return -1; }
    for (I r = 0; r < n; r++) {
        for (I j = 0; j < m; j++) {
            double wj = weights[r * m + j];
            x[j] = wj > 0 ? points[r * m + j] : 0.0;
            w[j] = wj;
        }
        out[r] = median_w(x, w, m, scratch);
    }
    free(x); free(w); free(scratch);
    return 0;
}

/* ------------------------------------------------------------------ the exponential of eqs. (16), (18) */

/* exp(x), written so that the loops calling it vectorise (libm's exp is a call per sample: eqs. (16)
 * and (18) on every sample of a sensor's corrected signal, and a translation's 768 x 160 profiles, were
 * 6 % of a diagnosis): x = k ln2 + r, k = round(x log2 e) by the 1.5 * 2^52 shift, r with ln2 in two
 * parts (Cody & Waite: k ln2hi is exact), exp(r) by its Taylor polynomial to degree 13 (|r| <= ln2 / 2:
 * the truncation 4e-18), times 2^k built from the exponent's bits, in two steps near the range's ends
 * (2^1024, and subnormal results, rounded once). Within 1 ulp of the correctly rounded value, at
 * most 1.16 ulp from the exact one (tests/test_kernels.py, over the whole range; 90 % exact); inf
 * above 709.78, 0 below -745.13, NaN kept. (Its loops vectorise from SSE4.2 on; with no -march
 * they stay scalar, about twice libm's time.)
 * fdi._jit._vexp takes the same operations: the numba path's bits. */
static inline double vexp(double x)
{
    const double shift = 0x1.8p52, log2e = 0x1.71547652b82fep+0;
    const double ln2hi = 0x1.62e42fee00000p-1, ln2lo = 0x1.a39ef35793c76p-33;
    double xc = x > 710.0 ? 710.0 : (x < -746.0 ? -746.0 : x);
    double kd = xc * log2e + shift;
    uint64_t kb;
    memcpy(&kb, &kd, sizeof kb);                         /* round(x log2 e) + 1.5 * 2^52 in the low bits */
    kd -= shift;
    double r = (xc - kd * ln2hi) - kd * ln2lo;
    double p = 1.0 + r * (1.0 + r * (0x1p-1 + r * (0x1.5555555555555p-3 + r * (0x1.5555555555555p-5
             + r * (0x1.1111111111111p-7 + r * (0x1.6c16c16c16c17p-10 + r * (0x1.a01a01a01a01ap-13
             + r * (0x1.a01a01a01a01ap-16 + r * (0x1.71de3a556c734p-19 + r * (0x1.27e4fb7789f5cp-22
             + r * (0x1.ae64567f544e4p-26 + r * (0x1.1eed8eff8d898p-29 + r * 0x1.6124613a86d09p-33))))))))))));
    int64_t adj = kd > 1000.0 ? -600 : (kd < -1000.0 ? 600 : 0);
    uint64_t e = (kb + (uint64_t)(1023 + adj)) << 52;
    double scale;
    memcpy(&scale, &e, sizeof scale);
    double fix = kd > 1000.0 ? 0x1p600 : (kd < -1000.0 ? 0x1p-600 : 1.0);
    double y = (p * scale) * fix;
    y = x > 709.782712893384 ? INFINITY : y;
    y = x < -745.1332191019412 ? 0.0 : y;
    return x != x ? x : y;
}

/* ------------------------------------------------------------------ cos, sin and tan of the tapes */

/* cos, sin and tan written so that the tapes' loops over samples vectorise (libm's are a call per
 * sample: the CyCab's ARR2 and ARR3 take a cosine and a tangent of the corrected steering angle on
 * every sample of every individual that corrects it, 7 % of a diagnosis). FreeBSD's msun (Sun's
 * fdlibm, Bruce Evans' kernels) with its branches as selects: x = n pi/2 + (y0 + y1), n by the
 * 1.5 * 2^52 shift, pi/2 in three 33-bit parts and a tail (Cody & Waite: exact products for
 * |n| < 2^20) subtracted by two two-sums (fdi.trig's docstring says why), then __kernel_cos,
 * __kernel_sin and __kernel_tan (tan's -1/w by a split of 26 bits, Veltkamp's, in place of clearing
 * the low word): within 0.8 ulp (tests/test_kernels.py against mpmath, the closest arguments to
 * multiples of pi/2 among them). Beyond |x| = 1.5 * 2^20, and for inf and NaN, libm's own (the second
 * loop of each operation in run_tape). fdi.trig._trig takes the same operations: the numba path's bits. */
#define TRIG_LIMIT 0x1.8p20

static inline double rem_pio2(double x, double *tail, uint64_t *quadrant)
{
    const double shift = 0x1.8p52, invpio2 = 0x1.45f306dc9c883p-1;
    const double p1 = 0x1.921fb54400000p+0, p2 = 0x1.0b4611a600000p-34;
    const double p3 = 0x1.3198a2e000000p-69, p3t = 0x1.b839a252049c1p-104;
    double fn = x * invpio2 + shift;
    uint64_t nb;
    memcpy(&nb, &fn, sizeof nb);                    /* round(x 2/pi) + 1.5 * 2^52 in the low bits */
    *quadrant = nb & 3;
    fn -= shift;
    double r = x - fn * p1;                         /* exact: fn p1 is, and x is near it */
    double s = fn * p2;                             /* exact */
    double h = r - s;
    double e = h - r;                               /* r - s = h + err (Knuth's two-sum) */
    double err = (r - (h - e)) + (-s - e);
    double t = fn * p3;                             /* exact */
    double h2 = h - t;
    double e2 = h2 - h;                             /* h - t = h2 + its error, a second two-sum */
    double lo = (err + ((h - (h2 - e2)) + (-t - e2))) - fn * p3t;
    double y0 = h2 + lo;
    *tail = (h2 - y0) + lo;
    return y0;
}

static inline double kcos(double x, double y)
{
    double z = x * x, w = z * z;
    double r = z * (0x1.555555555554cp-5 + z * (-0x1.6c16c16c15177p-10 + z * 0x1.a01a019cb159p-16))
             + w * w * (-0x1.27e4f809c52adp-22 + z * (0x1.1ee9ebdb4b1c4p-29 + z * -0x1.8fae9be8838d4p-37));
    double hz = 0.5 * z;
    double v = 1.0 - hz;
    return v + (((1.0 - v) - hz) + (z * r - x * y));
}

static inline double ksin(double x, double y)
{
    double z = x * x, w = z * z;
    double r = 0x1.111111110f8a6p-7 + z * (-0x1.a01a019c161d5p-13 + z * 0x1.71de357b1fe7dp-19)
             + z * w * (-0x1.ae5e68a2b9cebp-26 + z * 0x1.5d93a5acfd57cp-33);
    double v = z * x;
    return x - ((z * (0.5 * y - v * r) - y) - v * -0x1.5555555555549p-3);
}

static inline double split_hi(double a)           /* a's leading 26 bits (Veltkamp) */
{
    double c = a * 134217729.0;
    return c - (c - a);
}

static inline double ktan(double x, double y, int odd)
{
    int big = fabs(x) >= 0x1.59428p-1, neg = x < 0;
    double xs = neg ? -x : x, ys = neg ? -y : y;
    double xb = (0x1.921fb54442d18p-1 - xs) + (0x1.1a62633145c07p-55 - ys);
    double xx = big ? xb : x, yy = big ? 0.0 : y;
    double z = xx * xx, w = z * z;
    double r = 0x1.111111110fe7ap-3 + w * (0x1.664f48406d637p-6 + w * (0x1.d6d22c9560328p-9
             + w * (0x1.344d8f2f26501p-11 + w * (0x1.47e88a03792a6p-14 + w * -0x1.375cbdb605373p-16))));
    double v = z * (0x1.ba1ba1bb341fep-5 + w * (0x1.226e3e96e8493p-7 + w * (0x1.7dbc8fee08315p-10
             + w * (0x1.026f71a8d1068p-12 + w * (0x1.2b80f32f0a7e9p-14 + w * 0x1.b2a7074bf7ad4p-16)))));
    double s = z * xx;
    r = (yy + z * (s * (r + v) + yy)) + s * 0x1.5555555555563p-2;
    w = xx + r;
    double iy = odd ? -1.0 : 1.0;
    double near = iy - 2.0 * (xx - (w * w / (w + iy) - r));
    double folded = neg ? -near : near;
    double zh = split_hi(w);
    double vv = r - (zh - xx);                        /* zh + vv = xx + r */
    double a = -1.0 / w;
    double th = split_hi(a);
    double inverse = th + a * ((1.0 + th * zh) + th * vv);
    return big ? folded : (odd ? inverse : w);
}

/* which: 0 cos, 1 sin, 2 tan; |x| < TRIG_LIMIT (the callers take libm's beyond) */
static inline double vtrig(double x, int which)
{
    double y1;
    uint64_t q;
    double y0 = rem_pio2(x, &y1, &q);
    double out;
    if (which == 2)
        out = ktan(y0, y1, (int)(q & 1));
    else {
        double c = kcos(y0, y1), s = ksin(y0, y1);
        q = (q + (which == 1 ? 3 : 0)) & 3;
        out = q == 0 ? c : (q == 1 ? -s : (q == 2 ? -c : s));
    }
    return which != 0 && x == 0 ? x : out;      /* sin and tan keep the sign of zero (the reduction loses it) */
}

/* out[i] = cos, sin or tan (which 0, 1, 2) of x[i]: the tapes' loop (run_tape) */
static void trig_loop(const double *restrict x, I n, int which, double *restrict out)
{
    if (which == 0) for (I i = 0; i < n; i++) out[i] = vtrig(x[i], 0);
    else if (which == 1) for (I i = 0; i < n; i++) out[i] = vtrig(x[i], 1);
    else for (I i = 0; i < n; i++) out[i] = vtrig(x[i], 2);
    for (I i = 0; i < n; i++)
        if (!(fabs(x[i]) < TRIG_LIMIT))
            out[i] = which == 0 ? cos(x[i]) : (which == 1 ? sin(x[i]) : tan(x[i]));
}

int trig(const double *x, I n, I which, double *out)
{
    trig_loop(x, n, (int)which, out);
    return 0;
}

/* ------------------------------------------------------------------ eqs. (15) and (17) */

static double intermittent1(double t, double a, double nominal, double v, double T)
{
    if (!(t >= a)) return nominal;
    double x = 2 * PI * (t - a) / T;
    double u = x / PI;
    double kf = floor(u);
    double f = u - kf;
    double s;
    if (f > 1e-6 && f < 1 - 1e-6)
        s = ((I)kf & 1) == 0 ? 1.0 : -1.0;          /* Python's k % 2 == 0, negative k too */
    else {
        double y = sin(x);
        s = y > 0 ? 1.0 : (y < 0 ? -1.0 : 0.0);
    }
    return s > 0 ? v : (s < 0 ? nominal : (nominal + v) / 2);
}

/* intermittent1 over a row of samples, its values: one pass without branches (vectorised) decides
 * every sample whose phase is clear of a switching instant (f within (1e-6, 1 - 1e-6): the parity
 * of floor(u) alone, read as floor(kf / 2) != kf / 2, which is (I)kf & 1 for every kf that cast
 * defines); the samples at an instant (rare) are then done by intermittent1 itself, with sin */
static void intermittent_row(const double *t, I n, double a, double nominal, double v, double T, double *out)
{
    int edge = 0;
    for (I i = 0; i < n; i++) {
        double x = 2 * PI * (t[i] - a) / T;
        double u = x / PI;
        double kf = floor(u);
        double f = u - kf;
        double half = kf * 0.5;
        int odd = floor(half) != half;
        int after = t[i] >= a;
        out[i] = after & !odd ? v : nominal;
        edge |= after & !((f > 1e-6) & (f < 1 - 1e-6));
    }
    if (edge)
        for (I i = 0; i < n; i++) {
            double x = 2 * PI * (t[i] - a) / T;
            double u = x / PI;
            double f = u - floor(u);
            if (t[i] >= a && !(f > 1e-6 && f < 1 - 1e-6)) out[i] = intermittent1(t[i], a, nominal, v, T);
        }
}

int intermittent(const double *t, I n, const double *t0, I rows, double nominal, const double *value,
                 const double *period, double *out)
{
    for (I r = 0; r < rows; r++)
        intermittent_row(t, n, t0[r], nominal, value[r], period[r], out + r * n);
    return 0;
}

static double eq17(double t, double a, double nominal, double c, double b)
{
    if (!(t >= a)) return nominal;
    double tau = t - a;
    if (!(tau > 0)) return nominal;
    double den = c - b * tau;
    return den > 0 ? 1.0 / den : INFINITY;
}

int incipient17(const double *t, I n, const double *t0, I rows, double nominal, const double *b2, double *out)
{
    double c = isinf(nominal) ? 0.0 : 1.0 / nominal;
    for (I r = 0; r < rows; r++)
        for (I j = 0; j < n; j++)
            out[r * n + j] = eq17(t[j], t0[r], nominal, c, b2[r]);
    return 0;
}

/* ------------------------------------------------------------------ eqs. (16) and (18) */

static void eq18_roots(double b3, double *r1, double *r2)
{
    double root = sqrt(b3 * b3 + 4.0);
    *r1 = (b3 + root) / 2;
    *r2 = (b3 - root) / 2;
}

/* eq. (16) (model 1: P0 exp(b1 tau)) or eq. (18) (model 3, finite P0: -b4 + a exp(r1 tau) + c exp(r2 tau))
 * from t0 on, the nominal value before: fdi.profiles.incipient's operations in its order, the
 * exponential vexp's (numpy's own differs in the last bit: compared at 1e-9). b (rows, bc) -> out (rows, n) */
int incipient_exp(const double *t, I n, const double *t0, double nominal, I model, const double *b, I rows, I bc,
                  double *out)
{
    for (I r = 0; r < rows; r++) {
        double a = t0[r];
        if (model == 1) {
            double r1 = b[r * bc];
            for (I i = 0; i < n; i++) {
                double x = t[i] - a;
                double tau = x < 0 ? 0.0 : x;
                out[r * n + i] = t[i] >= a ? nominal * vexp(r1 * tau) : nominal;
            }
        } else {
            double b4 = b[r * bc + 1], r1, r2;
            eq18_roots(b[r * bc], &r1, &r2);
            double ca = -r2 * (nominal + b4) / (r1 - r2);
            double cc = r1 * (nominal + b4) / (r1 - r2);
            for (I i = 0; i < n; i++) {
                double x = t[i] - a;
                double tau = x < 0 ? 0.0 : x;
                out[r * n + i] = t[i] >= a ? (-b4 + ca * vexp(r1 * tau)) + cc * vexp(r2 * tau) : nominal;
            }
        }
    }
    return 0;
}

/* ------------------------------------------------------------------ the filter */

/* fir_row's sums for K (1 to 3) orders, eight outputs at a time in GCC/clang vectors: each
   output's sum takes the same operations in the same order as the tap-by-tap loops (mid * c0, then
   (up + down) * c_j or (up - down) * c_j added for j = 1..h), so the same bits (IEEE operations lane
   by lane, no contraction), without storing the pairs and the sums between taps. S1, S2: the
   second and third orders' rows (read only for K > 1, K > 2). */
typedef double v4d __attribute__((vector_size(32)));
static inline v4d ld4(const double *p) { v4d v; memcpy(&v, p, sizeof v); return v; }
static inline void st4(double *p, v4d v) { memcpy(p, &v, sizeof v); }
#define FIR_LANES_K(K)                                                                                      \
static void fir_lanes##K(const double *mid, const double *const *up, const double *const *down, I h,      \
                         const double *half, I hs, I count, double *S0, double *S1, double *S2)          \
{                                                                                                          \
    (void)S1; (void)S2;                                                                                    \
    I i = 0;                                                                                               \
    for (; i + 8 <= count; i += 8) {                                                                       \
        v4d m0 = ld4(mid + i), m1 = ld4(mid + i + 4);                                                      \
        v4d a0 = m0 * half[0], b0 = m1 * half[0];                                                          \
        v4d a1 = m0 * (K > 1 ? half[1] : 0.0), b1 = m1 * (K > 1 ? half[1] : 0.0);                         \
        v4d a2 = m0 * (K > 2 ? half[2] : 0.0), b2 = m1 * (K > 2 ? half[2] : 0.0);                         \
        for (I j = 1; j <= h; j++) {                                                                       \
            const double *c = half + j * hs;                                                               \
            v4d u0 = ld4(up[j] + i), u1 = ld4(up[j] + i + 4), d0 = ld4(down[j] + i), d1 = ld4(down[j] + i + 4); \
            v4d p0 = u0 + d0, p1 = u1 + d1;                                                                \
            a0 += p0 * c[0]; b0 += p1 * c[0];                                                              \
            if (K > 1) { a1 += (u0 - d0) * c[1]; b1 += (u1 - d1) * c[1]; }                                 \
            if (K > 2) { a2 += p0 * c[2]; b2 += p1 * c[2]; }                                               \
        }                                                                                                  \
        st4(S0 + i, a0); st4(S0 + i + 4, b0);                                                              \
        if (K > 1) { st4(S1 + i, a1); st4(S1 + i + 4, b1); }                                               \
        if (K > 2) { st4(S2 + i, a2); st4(S2 + i + 4, b2); }                                               \
    }                                                                                                      \
    for (; i < count; i++) {                                                                               \
        double a0 = mid[i] * half[0], a1 = K > 1 ? mid[i] * half[1] : 0.0, a2 = K > 2 ? mid[i] * half[2] : 0.0; \
        for (I j = 1; j <= h; j++) {                                                                       \
            double u = up[j][i], d = down[j][i];                                                           \
            a0 += (u + d) * half[j * hs];                                                                  \
            if (K > 1) a1 += (u - d) * half[j * hs + 1];                                                   \
            if (K > 2) a2 += (u + d) * half[j * hs + 2];                                                   \
        }                                                                                                  \
        S0[i] = a0;                                                                                        \
        if (K > 1) S1[i] = a1;                                                                             \
        if (K > 2) S2[i] = a2;                                                                             \
    }                                                                                                      \
}
FIR_LANES_K(1)
FIR_LANES_K(2)
FIR_LANES_K(3)

/* fdi._jit._fir_row: src (nsrc), half (hrows, hcols) with row stride hs; into S[(at + k) * ss + i];
 * phases: min(stride, n) rows of pw; plus, minus: count each */
static void fir_row(const double *src, I nsrc, const double *half, I hrows, I hcols, I hs, I start, I count,
                    I stride, double *S, I ss, I at, double *phases, I pw, double *plus, double *minus)
{
    I h = hrows - 1;
    I n = 2 * h + 1;
    I length = count + (n - 1) / stride + 1;
    const double *base = phases;
    if (stride == 1) {
        I stop = imin(start + count + n - 1, nsrc);
        if (stop == start + count + n - 1)
            base = src + start;              /* every tap inside the source: read it in place */
        else if (stop > start)
            memcpy(phases, src + start, sizeof(double) * (stop - start));
    } else {
        I nph = imin(stride, n);
        for (I ph = 0; ph < nph; ph++)
            for (I t = 0; t < length; t++) {
                I q = start + ph + t * stride;
                phases[ph * pw + t] = q < nsrc ? src[q] : 0.0;
            }
    }
    const double *mid = base + (h % stride) * pw + h / stride;
    if (hcols >= 1 && hcols <= 3 && h <= 1024) {      /* the taps' pointers on the stack: 16 kB at most */
        const double *up[h + 1], *down[h + 1];
        for (I j = 1; j <= h; j++) {
            up[j] = base + ((h + j) % stride) * pw + (h + j) / stride;
            down[j] = base + ((h - j) % stride) * pw + (h - j) / stride;
        }
        double *S0 = S + at * ss;
        if (hcols == 1) fir_lanes1(mid, up, down, h, half, hs, count, S0, S0, S0);
        else if (hcols == 2) fir_lanes2(mid, up, down, h, half, hs, count, S0, S0 + ss, S0);
        else fir_lanes3(mid, up, down, h, half, hs, count, S0, S0 + ss, S0 + 2 * ss);
        return;
    }
    for (I k = 0; k < hcols; k++) {
        double *acc = S + (at + k) * ss;
        double c = half[k];
        for (I i = 0; i < count; i++) acc[i] = mid[i] * c;
    }
    for (I j = 1; j <= h; j++) {
        const double *up = base + ((h + j) % stride) * pw + (h + j) / stride;
        const double *down = base + ((h - j) % stride) * pw + (h - j) / stride;
        for (I i = 0; i < count; i++) {
            plus[i] = up[i] + down[i];
            minus[i] = up[i] - down[i];
        }
        for (I k = 0; k < hcols; k++) {
            double *acc = S + (at + k) * ss;
            double c = half[j * hs + k];
            const double *v = (k % 2) ? minus : plus;
            for (I i = 0; i < count; i++) acc[i] += v[i] * c;
        }
    }
}

/* fdi.derivatives.edges_seen for order 0: per row, the sharp steps of edges (rows, ne; NaN: none)
   times signs (srows = 1: one row for all) summed sample by sample (exact: sums of +-1), then each
   edge's blend sign * (seen[k] - (k >= h)) added at q - h + k where h <= that < nw - h (q the first
   sample at or after the edge), edge after edge in (row, column) order: np.add.at's order, so the
   same bits where two edges' windows meet. seen (2 h) is the smoothing filter's view of a step;
   blends = 0 when no window fits. out (rows, nw). */
static I first_at_or_after(const double *t, I n, double x)
{
    I lo = 0, hi = n;
    while (lo < hi) {
        I mid = lo + (hi - lo) / 2;
        if (t[mid] < x) lo = mid + 1; else hi = mid;
    }
    return lo;
}

int edges_seen0(const double *t, I nw, const double *edges, I rows, I ne, const double *signs, I srows,
                const double *seen, I h, I blends, double *out)
{
    double *jumps = malloc(sizeof(double) * (nw + 1));
    if (!jumps) return -1;
    for (I r = 0; r < rows; r++) {
        const double *er = edges + r * ne, *sr = signs + (srows == 1 ? 0 : r * ne);
        double *o = out + r * nw;
        for (I i = 0; i <= nw; i++) jumps[i] = 0.0;
        for (I e = 0; e < ne; e++)
            if (isfinite(er[e])) jumps[first_at_or_after(t, nw, er[e])] += sr[e];
        double acc = 0.0;
        for (I i = 0; i < nw; i++) { acc += jumps[i]; o[i] = acc; }
        if (!blends) continue;
        for (I e = 0; e < ne; e++) {
            if (!isfinite(er[e])) continue;
            I q = first_at_or_after(t, nw, er[e]);
            if (q >= nw) continue;
            double s = sr[e];
            for (I k = 0; k < 2 * h; k++) {
                I a = q - h + k;
                if (a >= h && a < nw - h) o[a] += s * (seen[k] - (k >= h ? 1.0 : 0.0));
            }
        }
    }
    free(jumps);
    return 0;
}

/* An intermittent linear fault's unit square waves as the order-0 filter sees them, mapped to the
 * fault's values (fdi.objective.Objective.seen_steps with periods, in one pass): eq. (15)'s edges
 * as fdi.profiles.intermittent_edges lays them out (every row M rises t0 + m T and M falls half a
 * period later, M from the population's earliest onset and shortest period, NaN past t_end or for
 * an onset or period that is not a finite positive number), edges_seen0 over them, then
 * fdi.objective.seen_profile: the unit value where the wave is 1, the nominal where 0, between them
 * from_u(u0 + (to_u(unit) - u0) s) (transform 0: identity, 1: reciprocal). The same operations in
 * the same order: numpy's bits. out (rows, nw) */
int square_seen(const double *t, I nw, double t_end, const double *t0, const double *period, I rows,
                const double *seen, I h, I blends, I transform, double nominal, double unit, double *out)
{
    double lo = INFINITY, shortest = INFINITY;
    int any = 0;
    for (I r = 0; r < rows; r++) {
        if (isfinite(t0[r]) && isfinite(period[r]) && period[r] > 0) {
            any = 1;
            if (t0[r] < lo) lo = t0[r];
            if (period[r] < shortest) shortest = period[r];
        }
    }
    double span = any ? t_end - lo : 0.0;
    if (!any) shortest = 1.0;
    double ratio = ceil(span / shortest);
    if (!(ratio < 1e8)) return -2;                   /* (numpy would need the same impossible table) */
    I M = (ratio > 0 ? (I)ratio : 0) + 1;
    I ne = 2 * M;
    double *edges = malloc(sizeof(double) * (size_t)(rows > 0 ? rows : 1) * (size_t)ne);
    double *signs = malloc(sizeof(double) * (size_t)ne);
    if (!edges || !signs) { free(edges); free(signs); return -1; }
    for (I m = 0; m < M; m++) { signs[m] = 1.0; signs[M + m] = -1.0; }
    for (I r = 0; r < rows; r++) {
        int ok = isfinite(t0[r]) && isfinite(period[r]) && period[r] > 0;
        double half = period[r] / 2;
        for (I m = 0; m < M; m++) {
            double rise = ok ? t0[r] + (double)m * period[r] : NAN;
            double fall = rise + half;
            edges[r * ne + m] = rise > t_end ? NAN : rise;
            edges[r * ne + M + m] = fall > t_end ? NAN : fall;
        }
    }
    int rc = edges_seen0(t, nw, edges, rows, ne, signs, 1, seen, h, blends, out);
    free(edges); free(signs);
    if (rc) return rc;
    double u0 = transform ? 1.0 / nominal : nominal;
    double d = (transform ? 1.0 / unit : unit) - u0;
    for (I k = 0; k < rows * nw; k++) {
        double s = out[k];
        double v = s == 1.0 ? unit : nominal;
        if (s != 0.0 && s != 1.0) {
            double x = u0 + d * s;
            v = transform ? 1.0 / x : x;
        }
        out[k] = v;
    }
    return 0;
}

/* x (rows, nx), half (hrows, hcols) -> out (rows, hcols, count) */
int fir(const double *x, I rows, I nx, const double *half, I hrows, I hcols, I start, I count, I stride, double *out)
{
    I n = 2 * (hrows - 1) + 1;
    I length = count + (n - 1) / stride + 1;
    I nph = imin(stride, n);
    double *phases = malloc(sizeof(double) * (nph * length + count + n));
    double *pair = malloc(sizeof(double) * (2 * count + 2));
    if (!phases || !pair) { free(phases); free(pair); return -1; }
    for (I r = 0; r < rows; r++)
        fir_row(x + r * nx, nx, half, hrows, hcols, hcols, start, count, stride, out + r * hcols * count, count, 0,
                phases, length, pair, pair + count);
    free(phases); free(pair);
    return 0;
}

/* ------------------------------------------------------------------ decoding */

int decode_rows(const double *real, I pop, I nr, const B *bits, I nb, const B *log_, const double *scale,
                const double *powers, I npw, const I *vpow, const I *zeta, double t_last, I nf,
                I *kinds, I *models, double *values, double *periods, double *b, I *pre_at, I *counts,
                double *span19, B *level)
{
    for (I j = 0; j < nf; j++) {
        counts[2 * j] = counts[2 * j + 1] = 0;
        span19[j] = 0.0;
        level[j] = 0;
    }
    for (I j = 0; j < nf; j++) {
        I c0 = 9 * j, z0 = 5 * j;
        double late_max = -INFINITY;
        int seen = 0;
        for (I r = 0; r < pop; r++) {
            const B *br = bits + r * nb;
            I kind = zeta[4 * br[z0] + 2 * br[z0 + 1] + br[z0 + 2]];
            I model = 1 + 2 * (I)br[z0 + 3] + (I)br[z0 + 4];
            kinds[j * pop + r] = kind;
            models[j * pop + r] = model;
            const double *rr = real + r * nr;
            values[j * pop + r] = log_[j] ? powers[r * npw + vpow[j]] : rr[c0];
            periods[j * pop + r] = rr[c0 + 1];
            double *bb = b + (j * pop + r) * 7;
            for (I q = 0; q < 7; q++) bb[q] = rr[c0 + 2 + q] * scale[j * 7 + q];
            double rate = powers[r * npw + j];
            bb[2] = rate - 1.0 / rate;
            if (kind < 2) level[j] = 1;
            else if (model == 1) counts[2 * j]++;
            else if (model == 3) counts[2 * j + 1]++;
            else if (model == 4) {
                double late = t_last - rr[nr - 1];
                if (late == late) {
                    seen = 1;
                    if (late > late_max) late_max = late;
                }
            }
        }
        if (seen && late_max > 0.0) span19[j] = late_max;
    }
    for (I q = 0; q < nf * pop; q++) pre_at[q] = -1;
    return 0;
}

/* ------------------------------------------------------------------ the fused objective */

static double sign1(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : x); }

/* a tape on samples [s0, s0 + L) of one individual: R (registers, block) */
static void run_tape(const I *code, I ncode, double *R, I block, I L, I s0, const double *F, I fw, const double *P,
                     I pw, const double *S, I sw, const double *consts)
{
    for (I q = 0; q < ncode; q++) {
        I op = code[4 * q], a = code[4 * q + 2], bb = code[4 * q + 3];
        double *restrict out = R + code[4 * q + 1] * block;     /* never an operand (fdi.tape) */
        if (op == LOADF) { const double *src = F + a * fw + s0; for (I t = 0; t < L; t++) out[t] = src[t]; }
        else if (op == LOADP) { const double *src = P + a * pw + s0; for (I t = 0; t < L; t++) out[t] = src[t]; }
        else if (op == LOADS) { const double *src = S + a * sw + s0; for (I t = 0; t < L; t++) out[t] = src[t]; }
        else if (op == CONST) { double c = consts[a]; for (I t = 0; t < L; t++) out[t] = c; }
        else if (op < NEG) {
            const double *restrict u = R + a * block, *restrict v = R + bb * block;
            switch (op) {
            case ADD: for (I t = 0; t < L; t++) out[t] = u[t] + v[t]; break;
            case SUB: for (I t = 0; t < L; t++) out[t] = u[t] - v[t]; break;
            case MUL: for (I t = 0; t < L; t++) out[t] = u[t] * v[t]; break;
            case DIV: for (I t = 0; t < L; t++) out[t] = u[t] / v[t]; break;
            case POW: for (I t = 0; t < L; t++) out[t] = pow(u[t], v[t]); break;
            default: for (I t = 0; t < L; t++) out[t] = atan2(u[t], v[t]); break;
            }
        } else {
            const double *restrict u = R + a * block;
            switch (op) {
            case NEG: for (I t = 0; t < L; t++) out[t] = -u[t]; break;
            case ABS: for (I t = 0; t < L; t++) out[t] = fabs(u[t]); break;
            case SIGN: for (I t = 0; t < L; t++) out[t] = sign1(u[t]); break;
            case SQRT: for (I t = 0; t < L; t++) out[t] = sqrt(u[t]); break;
            case SQUARE: for (I t = 0; t < L; t++) out[t] = u[t] * u[t]; break;
            case RECIP: for (I t = 0; t < L; t++) out[t] = 1.0 / u[t]; break;
            case EXP: for (I t = 0; t < L; t++) out[t] = exp(u[t]); break;
            case LOG: for (I t = 0; t < L; t++) out[t] = log(u[t]); break;
            case SIN: trig_loop(u, L, 1, out); break;
            case COS: trig_loop(u, L, 0, out); break;
            case TAN: trig_loop(u, L, 2, out); break;
            case ASIN: for (I t = 0; t < L; t++) out[t] = asin(u[t]); break;
            case ACOS: for (I t = 0; t < L; t++) out[t] = acos(u[t]); break;
            case ATAN: for (I t = 0; t < L; t++) out[t] = atan(u[t]); break;
            case SINH: for (I t = 0; t < L; t++) out[t] = sinh(u[t]); break;
            case COSH: for (I t = 0; t < L; t++) out[t] = cosh(u[t]); break;
            case ASINH: for (I t = 0; t < L; t++) out[t] = asinh(u[t]); break;
            case ACOSH: for (I t = 0; t < L; t++) out[t] = acosh(u[t]); break;
            case ATANH: for (I t = 0; t < L; t++) out[t] = atanh(u[t]); break;
            default: for (I t = 0; t < L; t++) out[t] = tanh(u[t]); break;
            }
        }
    }
}

/* signal v corrected (fdi._jit._corrected): be / bi NULL for none */
static void corrected(const double *raw, I n, I v, const B *is_source, const double *be, const double *bi, I half,
                      double *cp)
{
    const double *restrict x0 = raw + v * n;
    double *restrict out = cp + half;
    int src = is_source[v];
    /* the branches taken once, outside the loops (each loop vectorises) */
    if (bi && src) for (I j = 0; j < n; j++) out[j] = x0[j] + bi[j];
    else if (bi) for (I j = 0; j < n; j++) out[j] = x0[j] - bi[j];
    else for (I j = 0; j < n; j++) out[j] = x0[j];
    if (be && src) for (I j = 0; j < n; j++) out[j] = out[j] * be[j];
    else if (be) for (I j = 0; j < n; j++) out[j] = out[j] / be[j];
    for (I j = 1; j <= half; j++) {
        cp[half - j] = cp[half + j];
        cp[half + n - 1 + j] = cp[half + n - 1 - j];
    }
}

/* the arguments of fused_cost: an int64 descriptor of five words per argument (an array's address
 * and its first four dimensions; an integer in the first word) and a double per argument (a float) */
enum { A_T, A_ONSET, A_KINDS, A_MODELS, A_VALUES, A_PERIODS, A_COEFFS, A_PRE, A_PRE_AT,
       A_F_NOMINAL, A_F_UNIT, A_F_LINEAR, A_F_ROLE, A_F_LO, A_F_HI, A_SPAN19, A_STEP19,
       A_SLOT_FAULT, A_SLOT_STEP, A_SLOT_GROUP, A_TNOM,
       A_CODE, A_RESULTS, A_REGISTERS, A_CONSTS, A_F,
       A_RAW, A_IS_SOURCE, A_BETA_FAULT, A_BETA_FIXED, A_BIAS_FAULT, A_BIAS_FIXED, A_CORR_FIXED,
       A_FK, A_FK_N, A_FK_ORDERS, A_S_AT, A_N_SLOTS, A_START, A_STRIDE, A_M,
       A_PLAIN, A_PLAIN_W, A_JOINT, A_JOINT_W, A_ENTERS, A_LIN_FAULT, A_LO, A_HI, A_PASSES, A_GAPS, A_CONSTANT,
       A_BLOCK, A_N_COMP, A_ICODE, A_LEVEL_AT, A_LEVEL_MEMBERS, A_MEMBERS, A_RESULT_OF, A_IREGISTERS, A_ICONSTS,
       A_IFIXED, A_FULL_OF, A_N_FULL, A_COMP_AT, A_FULL_AT, A_COMP_ORDER, A_CK, A_CK_N, A_EDGE, A_COUNT };

#define ADDR(i) ((void *)(intptr_t)D[5 * (i)])
#define DIM(i, k) (D[5 * (i) + 1 + (k)])
#define INT(i) (D[5 * (i)])

int fused_arity(void) { return A_COUNT; }

/* the profile of fault j for individual row (fdi._jit._profile) */
static void profile(const double *t, I nw, I j, I row, I pop, const double *onset, const I *kinds, const I *models,
                    const double *values, const double *periods, const double *coeffs, const double *pre, I prew,
                    const I *pre_at, double nominal, double unit, int linear, I k19, double h19,
                    const double *grid, const double *slope, double *out)
{
    I kind = kinds[j * pop + row];
    double a = onset[row];
    double val = (linear && kind < 2) ? unit : values[j * pop + row];
    if (kind < 2 && linear && pre_at[j * pop + row] >= 0) {      /* its step or square wave as the filters see it (numpy's) */
        const double *src = pre + pre_at[j * pop + row] * prew;
        for (I i = 0; i < nw; i++) out[i] = src[i];
    } else if (kind == 0) {
        double z = 0.0 * val;
        for (I i = 0; i < nw; i++) out[i] = (t[i] >= a ? val : nominal) + z;
    } else if (kind == 1) {
        double T = periods[j * pop + row];
        intermittent_row(t, nw, a, nominal, val, T, out);
    } else {
        I model = models[j * pop + row];
        const double *cf = coeffs + (j * pop + row) * NCOEFFS;
        if (model == 2) {
            if (nominal == 0) {
                for (I i = 0; i < nw; i++) out[i] = 0.0;
            } else {
                double c = isinf(nominal) ? 0.0 : 1.0 / nominal;
                double b = cf[0];
                for (I i = 0; i < nw; i++) out[i] = eq17(t[i], a, nominal, c, b);
            }
        } else if (model == 4) {
            if (isinf(nominal)) {
                for (I i = 0; i < nw; i++) out[i] = t[i] >= a ? INFINITY : nominal;
            } else {
                /* the grid made for this row before the rows' loop (fused_cost: rk4_grids; NULL for
                   any row but an eq. (19) one of a finite nominal value, which never reads it) */
                hermite_row(t, nw, a, nominal, h19, k19, grid, slope, out);
            }
        } else if (model == 1) {                 /* eq. (16): fdi.profiles.incipient's operations */
            double r1 = cf[4];
            for (I i = 0; i < nw; i++) {
                double x = t[i] - a;
                double tau = x < 0 ? 0.0 : x;
                out[i] = t[i] >= a ? nominal * vexp(r1 * tau) : nominal;
            }
        } else if (isinf(nominal)) {             /* eq. (18) never leaves an infinite P0 */
            for (I i = 0; i < nw; i++) out[i] = INFINITY;
        } else {                                 /* eq. (18) */
            double b4 = cf[6], r1, r2;
            eq18_roots(cf[5], &r1, &r2);
            double ca = -r2 * (nominal + b4) / (r1 - r2);
            double cc = r1 * (nominal + b4) / (r1 - r2);
            for (I i = 0; i < nw; i++) {
                double x = t[i] - a;
                double tau = x < 0 ? 0.0 : x;
                out[i] = t[i] >= a ? (-b4 + ca * vexp(r1 * tau)) + cc * vexp(r2 * tau) : nominal;
            }
        }
    }
}

/* the parameter slots of one individual at start, start + stride, ... (fdi._jit._slots) */
static void slots(const double *prof, I nw, const B *solved, const I *slot_fault, const B *slot_step,
                  const B *slot_group, I nslot, const double *f_nominal, const double *tnom, I start, I count, I stride,
                  double *out, I ow)
{
    for (I k = 0; k < nslot; k++) {
        I j = slot_fault[k];
        double *dst = out + k * ow;
        const double *tn = tnom + k * nw;
        if (solved[j] && !slot_step[k]) {
            double c = f_nominal[j];
            for (I s = 0; s < count; s++) dst[s] = slot_group[k] ? tn[start + s * stride] * c : c;
        } else {
            const double *src = prof + j * nw;
            for (I s = 0; s < count; s++) {
                I q = start + s * stride;
                dst[s] = slot_group[k] ? tn[q] * src[q] : src[q];
            }
        }
    }
}

static int others_sum(const double *d, const double *gain, const B *enters, I ne1, const B *srow, I nlin, I jj,
                      I ji, I nj1, I m, double *extra)
{
    int others = 0;
    for (I kk = 0; kk < nlin; kk++) {
        if (kk != jj && enters[kk * ne1 + ji] && srow[kk]) {
            double dk = d[kk];
            const double *g = gain + (kk * nj1 + ji) * m;
            if (others) for (I s = 0; s < m; s++) extra[s] = extra[s] + dk * g[s];
            else for (I s = 0; s < m; s++) extra[s] = dk * g[s];
            others = 1;
        }
    }
    return others;
}

static void points(const double *base, const double *extra, int others, const double *x, double w, I m, double *pts,
                   double *wts)
{
    for (I s = 0; s < m; s++) {
        double rest = others ? base[s] + extra[s] : base[s];
        double xs = x[s];
        int ok = (xs != 0) & (fabs(rest) < INFINITY) & (fabs(xs) < INFINITY);
        double wc = ok ? w * fabs(xs) : 0.0;
        double q = -rest / (xs != 0 ? xs : 1.0);
        wts[s] = wc;
        pts[s] = wc > 0 ? q : 0.0;
    }
}

#define NEW(p, n) do { (p) = calloc((size_t)((n) > 0 ? (n) : 1), sizeof(*(p))); if (!(p)) goto fail; } while (0)

int fused_cost(const I *D, const double *X, double *total, double *deltas, B *invalid)
{
    const double *t = ADDR(A_T), *onset = ADDR(A_ONSET), *values = ADDR(A_VALUES), *periods = ADDR(A_PERIODS);
    const double *coeffs = ADDR(A_COEFFS), *pre = ADDR(A_PRE);
    const I *kinds = ADDR(A_KINDS), *models = ADDR(A_MODELS), *pre_at = ADDR(A_PRE_AT);
    const double *f_nominal = ADDR(A_F_NOMINAL), *f_unit = ADDR(A_F_UNIT), *f_lo = ADDR(A_F_LO), *f_hi = ADDR(A_F_HI);
    const B *f_linear = ADDR(A_F_LINEAR);
    const I *f_role = ADDR(A_F_ROLE);
    const double *span19 = ADDR(A_SPAN19);
    double step19 = X[A_STEP19];
    const I *slot_fault = ADDR(A_SLOT_FAULT);
    const B *slot_step = ADDR(A_SLOT_STEP), *slot_group = ADDR(A_SLOT_GROUP);
    const double *tnom = ADDR(A_TNOM);
    const I *code = ADDR(A_CODE), *results = ADDR(A_RESULTS);
    I registers = INT(A_REGISTERS);
    const double *consts = ADDR(A_CONSTS), *F = ADDR(A_F);
    const double *raw = ADDR(A_RAW), *corr_fixed = ADDR(A_CORR_FIXED);
    const B *is_source = ADDR(A_IS_SOURCE);
    const I *beta_fault = ADDR(A_BETA_FAULT), *beta_fixed = ADDR(A_BETA_FIXED);
    const I *bias_fault = ADDR(A_BIAS_FAULT), *bias_fixed = ADDR(A_BIAS_FIXED);
    const double *fk = ADDR(A_FK);
    const I *fk_n = ADDR(A_FK_N), *fk_orders = ADDR(A_FK_ORDERS), *s_at = ADDR(A_S_AT);
    I n_slots = INT(A_N_SLOTS), start = INT(A_START), stride = INT(A_STRIDE), m = INT(A_M);
    const I *plain = ADDR(A_PLAIN), *joint = ADDR(A_JOINT), *lin_fault = ADDR(A_LIN_FAULT);
    const double *plain_w = ADDR(A_PLAIN_W), *joint_w = ADDR(A_JOINT_W), *lo = ADDR(A_LO), *hi = ADDR(A_HI);
    const B *enters = ADDR(A_ENTERS), *gaps = ADDR(A_GAPS);
    I passes = INT(A_PASSES), block = INT(A_BLOCK), n_comp = INT(A_N_COMP);
    double constant = X[A_CONSTANT];
    const I *icode = ADDR(A_ICODE), *level_at = ADDR(A_LEVEL_AT), *level_members = ADDR(A_LEVEL_MEMBERS);
    const I *members = ADDR(A_MEMBERS), *result_of = ADDR(A_RESULT_OF);
    I iregisters = INT(A_IREGISTERS), n_full = INT(A_N_FULL);
    const double *iconsts = ADDR(A_ICONSTS), *ifixed = ADDR(A_IFIXED), *ck = ADDR(A_CK), *edge = ADDR(A_EDGE);
    const I *full_of = ADDR(A_FULL_OF), *comp_at = ADDR(A_COMP_AT), *full_at = ADDR(A_FULL_AT);
    const I *comp_order = ADDR(A_COMP_ORDER), *ck_n = ADDR(A_CK_N);

    I nf = DIM(A_KINDS, 0), pop = DIM(A_KINDS, 1);
    I nw = DIM(A_T, 0);
    I nlin = DIM(A_LIN_FAULT, 0), nj = DIM(A_JOINT, 0), npl = DIM(A_PLAIN, 0), nslot = DIM(A_SLOT_FAULT, 0);
    I prew = DIM(A_PRE, 1), rc = DIM(A_RESULTS, 1), ncode = DIM(A_CODE, 0), fw = DIM(A_F, 1);
    I ne1 = DIM(A_ENTERS, 1), nv = DIM(A_RAW, 0), cfw = DIM(A_CORR_FIXED, 1);
    I fk1 = DIM(A_FK, 1), fk2 = DIM(A_FK, 2), ck1 = DIM(A_CK, 1), ck2 = DIM(A_CK, 2);
    I fo1 = DIM(A_FULL_OF, 1), ifw = DIM(A_IFIXED, 1), nlev = DIM(A_LEVEL_AT, 0) - 1;
    I e1 = DIM(A_EDGE, 1), e2 = DIM(A_EDGE, 2), e3 = DIM(A_EDGE, 3);
    (void)cfw;
    I nlin1 = imax(1, nlin), nj1 = imax(1, nj), nf1 = imax(1, nf);
    int rc_ = -1;

    double *prof = NULL, *h19 = NULL, *ones = NULL, *zeros = NULL, *Prow = NULL;
    double *R = NULL, *S = NULL, *base = NULL, *gain = NULL, *pts = NULL, *wts = NULL, *d = NULL, *extra = NULL;
    double *seen = NULL, *parts = NULL, *cp = NULL, *Pfull = NULL, *Sfull = NULL, *Ri = NULL, *Xq = NULL;
    double *T = NULL, *phases_full = NULL, *pair_full = NULL, *phases = NULL, *pair = NULL, *scratch = NULL;
    B *bad = NULL, *solved = NULL, *fresh = NULL, *srow = NULL;
    I *k19 = NULL, *at19 = NULL, *off19 = NULL;
    double *g19 = NULL, *s19 = NULL, *c19 = NULL;

    NEW(prof, nf1 * nw); NEW(bad, nf1); NEW(solved, nf1); NEW(k19, nf1); NEW(h19, nf1);
    for (I j = 0; j < nf; j++) {
        double span = span19[j];
        k19[j] = steps19(span, step19);
        h19[j] = span > 0 ? span / k19[j] : step19;
    }
    NEW(ones, nw); NEW(zeros, nw);
    /* eq. (19)'s grids, every row's that needs one, made before the rows' loop eight at a time */
    NEW(at19, nf1 * pop); NEW(off19, nf1); NEW(c19, 3 * imax(1, pop));
    I tot19 = 0;
    for (I j = 0; j < nf; j++) {
        I c = 0;
        off19[j] = tot19;
        for (I row = 0; row < pop; row++)
            at19[j * pop + row] = (kinds[j * pop + row] >= 2 && models[j * pop + row] == 4 && !isinf(f_nominal[j]))
                                  ? c++ : -1;
        tot19 += c * (k19[j] + 1);
    }
    NEW(g19, tot19); NEW(s19, tot19);
    for (I j = 0; j < nf; j++) {
        I c = 0;
        for (I row = 0; row < pop; row++)
            if (at19[j * pop + row] >= 0) {
                const double *cf = coeffs + (j * pop + row) * NCOEFFS;
                c19[c] = cf[1]; c19[pop + c] = cf[2]; c19[2 * pop + c] = cf[3];
                c++;
            }
        if (c)
            rk4_grids(f_nominal[j], c19, c19 + pop, c19 + 2 * pop, 1, c, h19[j], k19[j], g19 + off19[j], s19 + off19[j]);
    }
    for (I i = 0; i < nw; i++) ones[i] = 1.0;
    I nslot1 = imax(1, nslot);
    NEW(Prow, nslot1 * m);
    NEW(R, imax(1, registers) * block);
    NEW(S, imax(1, n_slots) * m);
    NEW(base, nj1 * m);
    NEW(gain, nlin1 * nj1 * m);
    NEW(pts, nj1 * m); NEW(wts, nj1 * m);
    NEW(d, nlin1); NEW(extra, m); NEW(fresh, nlin1); NEW(seen, nlin1 * nlin1); NEW(srow, nlin1);
    NEW(parts, imax(1, npl));
    I nmax = 2 * (imax(fk1, ck1) - 1) + 1;
    NEW(cp, nw + nmax);
    NEW(Pfull, (n_comp ? nslot1 : 1) * nw);
    NEW(Sfull, (n_comp ? n_full : 1) * nw);
    NEW(Ri, (n_comp ? imax(1, iregisters) : 1) * block);
    I xw = n_comp ? nw : 1;
    NEW(Xq, imax(1, n_comp) * xw);
    I tr = imax(ck2, fk2);
    NEW(T, tr * xw);
    I pfw = n_comp ? nw + nmax : 1;
    NEW(phases_full, pfw);
    NEW(pair_full, 2 * xw);
    I nph = imax(1, imin(stride, nmax)), phw = m + (nmax - 1) / stride + 1;
    NEW(phases, nph * phw);
    NEW(pair, 2 * m);
    NEW(scratch, 2 * BRACKET_SAMPLE + 2 * nj1 * m + 2);

    for (I row = 0; row < pop; row++) {
        int inv = 0;
        for (I j = 0; j < nf; j++) {
            double *pj = prof + j * nw;
            profile(t, nw, j, row, pop, onset, kinds, models, values, periods, coeffs, pre, prew, pre_at, f_nominal[j],
                    f_unit[j], f_linear[j], k19[j], h19[j],
                    at19[j * pop + row] >= 0 ? g19 + off19[j] + at19[j * pop + row] * (k19[j] + 1) : NULL,
                    at19[j * pop + row] >= 0 ? s19 + off19[j] + at19[j * pop + row] * (k19[j] + 1) : NULL, pj);
            solved[j] = f_linear[j] && kinds[j * pop + row] < 2;
            int b = 0;
            if (!solved[j]) {      /* whether any sample is NaN or (role 1, 2) outside the bounds (role 1: > 0 too) */
                I role = f_role[j];
                double lo_j = f_lo[j], hi_j = f_hi[j];
                if (role == 1)
                    for (I i = 0; i < nw; i++) {
                        double x = pj[i];     /* one pass without branches (& not &&): vectorised */
                        b |= !((x > 0) & (lo_j <= x) & (x <= hi_j) & (fabs(x) < INFINITY));
                    }
                else if (role == 2)
                    for (I i = 0; i < nw; i++) {
                        double x = pj[i];
                        b |= !((lo_j <= x) & (x <= hi_j) & (fabs(x) < INFINITY));
                    }
                else
                    for (I i = 0; i < nw; i++) b |= pj[i] != pj[i];
            }
            bad[j] = b;
            inv = inv || b;
        }
        slots(prof, nw, solved, slot_fault, slot_step, slot_group, nslot, f_nominal, tnom, start, m, stride, Prow, m);
        for (I v = 0; v < nv; v++) {
            const double *be = NULL, *bi = NULL;
            if (beta_fault[v] >= 0) be = bad[beta_fault[v]] ? ones : prof + beta_fault[v] * nw;
            else if (beta_fixed[v] >= 0) be = corr_fixed + beta_fixed[v] * nw;
            if (bias_fault[v] >= 0) bi = bad[bias_fault[v]] ? zeros : prof + bias_fault[v] * nw;
            else if (bias_fixed[v] >= 0) bi = corr_fixed + bias_fixed[v] * nw;
            I h = fk_n[v] / 2;
            corrected(raw, nw, v, is_source, be, bi, h, cp);
            const double *half = fk + v * fk1 * fk2;
            fir_row(cp, nw + 2 * h, half, h + 1, fk_orders[v], fk2, start, m, stride, S, m, s_at[v], phases, phw,
                    pair, pair + m);
            if (n_comp) {
                if (full_of[v * fo1] >= 0) memcpy(Sfull + full_of[v * fo1] * nw, cp + h, sizeof(double) * nw);
                int deriv = 0;
                for (I k = 1; k < fo1; k++) deriv = deriv || full_of[v * fo1 + k] >= 0;
                if (deriv) {
                    fir_row(cp, nw + 2 * h, half, h + 1, fk_orders[v], fk2, 0, nw, 1, T, nw, 0, phases_full, pfw,
                            pair_full, pair_full + nw);
                    for (I k = 1; k < fo1; k++)
                        if (full_of[v * fo1 + k] >= 0)
                            memcpy(Sfull + full_of[v * fo1 + k] * nw, T + k * nw, sizeof(double) * nw);
                }
            }
        }
        if (n_comp) {
            slots(prof, nw, solved, slot_fault, slot_step, slot_group, nslot, f_nominal, tnom, 0, nw, 1, Pfull, nw);
            for (I lev = 0; lev < nlev; lev++) {
                const I *code_l = icode + 4 * level_at[lev];
                I ncl = level_at[lev + 1] - level_at[lev];
                for (I s0 = 0; s0 < nw; s0 += block) {
                    I L = imin(block, nw - s0);
                    run_tape(code_l, ncl, Ri, block, L, s0, ifixed, ifw, Pfull, nw, Sfull, nw, iconsts);
                    for (I k = level_members[lev]; k < level_members[lev + 1]; k++) {
                        I c = members[k];
                        memcpy(Xq + c * xw + s0, Ri + result_of[c] * block, sizeof(double) * L);
                    }
                }
                for (I k = level_members[lev]; k < level_members[lev + 1]; k++) {
                    I c = members[k];
                    I n = ck_n[c], h = n / 2, o = comp_order[c];
                    double *x = Xq + c * xw;
                    int nonfinite = 0;
                    for (I i = 0; i < nw; i++) {        /* non-finite values zeroed, without branches */
                        double v = x[i];
                        int finite = fabs(v) < INFINITY;
                        x[i] = finite ? v : 0.0;
                        nonfinite |= !finite;
                    }
                    inv = inv || nonfinite;
                    const double *half = ck + c * ck1 * ck2;
                    if (comp_at[c] >= 0 && start >= h && start + (m - 1) * stride + h < nw)
                        fir_row(x, nw, half, h + 1, o + 1, ck2, start - h, m, stride, S, m, comp_at[c], phases, phw,
                                pair, pair + m);
                    else if (comp_at[c] >= 0) {   /* samples within h of the window's ends: zeros beyond, then fitted */
                        for (I i = 0; i < h; i++) { cp[i] = 0.0; cp[h + nw + i] = 0.0; }
                        memcpy(cp + h, x, sizeof(double) * nw);
                        fir_row(cp, nw + 2 * h, half, h + 1, o + 1, ck2, start, m, stride, S, m, comp_at[c], phases, phw,
                                pair, pair + m);
                        const double *e0 = edge + c * e1 * e2 * e3, *e1p = e0 + e2 * e3;
                        double *out = S + (comp_at[c] + o) * m;
                        for (I j = 0; j < m; j++) {
                            I i = start + j * stride;
                            double a = 0.0;
                            if (i < h) {
                                for (I r = 0; r < n; r++) a += x[r] * e0[r * e3 + i];
                                out[j] = a;
                            } else if (i >= nw - h) {
                                for (I r = 0; r < n; r++) a += x[nw - n + r] * e1p[r * e3 + (i - (nw - h))];
                                out[j] = a;
                            }
                        }
                    }
                    if (full_at[c] >= 0) {
                        double *dst = Sfull + full_at[c] * nw;
                        fir_row(x, nw, half, h + 1, o + 1, ck2, 0, nw - 2 * h, 1, T, nw, 0, phases_full, pfw,
                                pair_full, pair_full + nw);
                        for (I i = 0; i < nw - 2 * h; i++) dst[h + i] = T[o * nw + i];
                        const double *e0 = edge + c * e1 * e2 * e3, *e1p = e0 + e2 * e3;
                        for (I q = 0; q < h; q++) {
                            double a0 = 0.0, a1 = 0.0;
                            for (I i = 0; i < n; i++) {
                                a0 += x[i] * e0[i * e3 + q];
                                a1 += x[nw - n + i] * e1p[i * e3 + q];
                            }
                            dst[q] = a0;
                            dst[nw - h + q] = a1;
                        }
                    }
                }
            }
        }
        invalid[row] = (B)inv;
        for (I jj = 0; jj < nlin; jj++) srow[jj] = solved[lin_fault[jj]];
        for (I pi = 0; pi < npl; pi++) parts[pi] = 0.0;
        for (I s0 = 0; s0 < m; s0 += block) {
            I L = imin(block, m - s0);
            run_tape(code, ncode, R, block, L, s0, F, fw, Prow, m, S, m, consts);
            for (I pi = 0; pi < npl; pi++) {
                const double *r = R + results[plain[pi] * rc] * block;
                double part = parts[pi];
                for (I u = 0; u < L; u++)
                    if (!gaps[s0 + u]) part += fabs(r[u]);
                parts[pi] = part;
            }
            for (I ji = 0; ji < nj; ji++) {
                I q = joint[ji];
                const double *r = R + results[q * rc] * block;
                double *bj = base + ji * m;
                for (I u = 0; u < L; u++) bj[s0 + u] = gaps[s0 + u] ? 0.0 : r[u];
                for (I jj = 0; jj < nlin; jj++)
                    if (enters[jj * ne1 + ji] && srow[jj]) {
                        const double *rv = R + results[q * rc + 1 + jj] * block;
                        double *g = gain + (jj * nj1 + ji) * m;
                        for (I u = 0; u < L; u++) g[s0 + u] = (gaps[s0 + u] ? 0.0 : rv[u]) - bj[s0 + u];
                    }
            }
        }
        double acc = constant;
        for (I pi = 0; pi < npl; pi++) acc += plain_w[pi] * parts[pi];
        if (nj) {
            for (I jj = 0; jj < nlin; jj++) { d[jj] = 0.0; fresh[jj] = 0; }
            for (I pass = 0; pass < passes; pass++) {
                for (I jj = 0; jj < nlin; jj++) {
                    if (!srow[jj]) { d[jj] = 0.0; continue; }
                    int same = fresh[jj];
                    for (I kk = 0; kk < nlin; kk++)
                        if (same && kk != jj && seen[jj * nlin1 + kk] != d[kk]) same = 0;
                    if (same) continue;
                    I c = 0;
                    for (I ji = 0; ji < nj; ji++) {
                        if (!enters[jj * ne1 + ji]) continue;
                        int oth = others_sum(d, gain, enters, ne1, srow, nlin, jj, ji, nj1, m, extra);
                        points(base + ji * m, extra, oth, gain + (jj * nj1 + ji) * m, joint_w[ji], m, pts + c, wts + c);
                        c += m;
                    }
                    double med = median_w(pts, wts, c, scratch);
                    d[jj] = pmin(pmax(med, lo[jj]), hi[jj]);
                    fresh[jj] = 1;
                    for (I kk = 0; kk < nlin; kk++) seen[jj * nlin1 + kk] = d[kk];
                }
            }
            for (I jj = 0; jj < nlin; jj++) deltas[jj * pop + row] = d[jj];
            for (I ji = 0; ji < nj; ji++) {
                int oth = others_sum(d, gain, enters, ne1, srow, nlin, -1, ji, nj1, m, extra);
                const double *b_ = base + ji * m;
                if (oth) for (I s = 0; s < m; s++) extra[s] = fabs(b_[s] + extra[s]);
                else for (I s = 0; s < m; s++) extra[s] = fabs(b_[s]);
                double part = 0.0;
                for (I s = 0; s < m; s++) part += extra[s];
                acc += joint_w[ji] * part;
            }
        }
        total[row] = acc;
    }
    rc_ = 0;
fail:
    free(prof); free(bad); free(solved); free(k19); free(h19); free(ones); free(zeros);
    free(Prow); free(R); free(S); free(base); free(gain); free(pts); free(wts); free(d); free(extra); free(fresh);
    free(seen); free(srow); free(parts); free(cp); free(Pfull); free(Sfull); free(Ri); free(Xq); free(T);
    free(phases_full); free(pair_full); free(phases); free(pair); free(scratch);
    free(at19); free(off19); free(c19); free(g19); free(s19);
    return rc_;
}
