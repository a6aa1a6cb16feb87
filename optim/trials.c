/* A DE generation's arithmetic in C99: optim._jit.trials line for line (the same operations in the
 * same order: the numba path's and numpy's bits). Built by optim.native (no contraction into fused
 * multiply-adds, no fast-math); loaded by optim/_native.py. Arrays are C-contiguous; bool arrays
 * are numpy's one byte per element. */
#include <stdint.h>
#include <stdlib.h>

typedef int64_t I;

int trials(const double *x, I n, I D, const I *cols, I m, const double *F_old, const double *CR_old,
           const double *redraw_F, const double *new_F, const double *redraw_CR, const double *new_CR,
           const I *order, const I *pick, const I *hop1, const I *hop2, const double *cross, const I *forced,
           const double *lo, const double *hi, double *trial, double *F, double *CR)
{
    for (I q = 0; q < n * D; q++) trial[q] = x[q];
    for (I i = 0; i < n; i++) {
        F[i] = redraw_F[i] < 0.1 ? new_F[i] : F_old[i];
        CR[i] = redraw_CR[i] < 0.1 ? new_CR[i] : CR_old[i];
    }
    for (I i = 0; i < n; i++) {
        I p = order[pick[i]];
        I r1 = (i + hop1[i]) % n;
        I r2 = (r1 + hop2[i]) % n;
        if (r2 == i) r2 = (r2 + 1) % n;
        double f = F[i];
        for (I k = 0; k < m; k++) {
            I c = cols[k];
            double xi = x[i * D + c];
            double v = xi + f * (x[p * D + c] - xi) + f * (x[r1 * D + c] - x[r2 * D + c]);
            double u = (cross[i * m + k] <= CR[i] || k == forced[i]) ? v : xi;
            if (u < lo[k]) u = (lo[k] + xi) / 2;
            if (u > hi[k]) u = (hi[k] + xi) / 2;
            trial[i * D + c] = u;
        }
    }
    return 0;
}

/* ------------------------------------------------------------------ a generation's trials, draws included */

/* numpy's bit generator interface (numpy/random/bitgen.h): the state and its functions, which
 * numpy's own Generator calls, so draws taken here advance the very stream numpy's methods read */
typedef struct {
    void *state;
    uint64_t (*next_uint64)(void *st);
    uint32_t (*next_uint32)(void *st);
    double (*next_double)(void *st);
    uint64_t (*next_raw)(void *st);
} bitgen_t;

/* Generator.integers(low, high) of one int64 for high - low <= 2**32 (numpy's
 * random_bounded_uint64_fill with Lemire's rejection on 32-bit draws: its draws, its number) */
static I bounded(bitgen_t *g, I low, I high)
{
    uint64_t rng = (uint64_t)(high - 1 - low);
    if (rng == 0) return low;
    if (rng == 0xFFFFFFFFULL) return low + (I)g->next_uint32(g->state);
    uint32_t r = (uint32_t)rng, excl = r + 1;
    uint64_t m = (uint64_t)g->next_uint32(g->state) * excl;
    uint32_t leftover = (uint32_t)m;
    if (leftover < excl) {
        uint32_t threshold = (UINT32_MAX - r) % excl;
        while (leftover < threshold) {
            m = (uint64_t)g->next_uint32(g->state) * excl;
            leftover = (uint32_t)m;
        }
    }
    return low + (I)(m >> 32);
}

/* For each of nb populations, optim.ahde.AHDE.trials' draws from numpy's generator ``g`` in its
 * order (random(n), uniform(0.1, 1.0, n), random(n), random(n), integers(0, top, n), integers(1, n,
 * n), integers(1, n - 1, n), random((n, m)), integers(0, m, n)), then ``trials``. desc: 14 words
 * per population: x, n, D, cols, m, F_old, CR_old, order, lo, hi, trial, F, CR, top (addresses, and
 * n, D, m, top). 3 <= n, 1 <= m, 2 <= top <= n, all below 2**32 (the caller's). Returns 1, having
 * drawn nothing, when scratch cannot be allocated (one allocation for the largest population). */
#define P(k) ((void *)(intptr_t)d[k])
int trials_batch(void *gen, I nb, const I *desc)
{
    bitgen_t *g = gen;
    I most = 0, cells = 0;
    for (I b = 0; b < nb; b++) {
        const I *d = desc + 14 * b;
        if (d[1] > most) most = d[1];
        if (d[1] * d[4] > cells) cells = d[1] * d[4];
    }
    double *u = malloc(sizeof(double) * (size_t)(4 * most + cells + 1));
    I *k = malloc(sizeof(I) * (size_t)(4 * most + 1));
    if (!u || !k) { free(u); free(k); return 1; }
    for (I b = 0; b < nb; b++) {
        const I *d = desc + 14 * b;
        I n = d[1], D = d[2], m = d[4], top = d[13];
        double *redraw_F = u, *new_F = u + n, *redraw_CR = u + 2 * n, *new_CR = u + 3 * n, *cross = u + 4 * n;
        I *pick = k, *hop1 = k + n, *hop2 = k + 2 * n, *forced = k + 3 * n;
        for (I i = 0; i < n; i++) redraw_F[i] = g->next_double(g->state);
        for (I i = 0; i < n; i++) new_F[i] = 0.1 + (1.0 - 0.1) * g->next_double(g->state);
        for (I i = 0; i < n; i++) redraw_CR[i] = g->next_double(g->state);
        for (I i = 0; i < n; i++) new_CR[i] = g->next_double(g->state);
        for (I i = 0; i < n; i++) pick[i] = bounded(g, 0, top);
        for (I i = 0; i < n; i++) hop1[i] = bounded(g, 1, n);
        for (I i = 0; i < n; i++) hop2[i] = bounded(g, 1, n - 1);
        for (I q = 0; q < n * m; q++) cross[q] = g->next_double(g->state);
        for (I i = 0; i < n; i++) forced[i] = bounded(g, 0, m);
        trials(P(0), n, D, P(3), m, P(5), P(6), redraw_F, new_F, redraw_CR, new_CR, P(7), pick, hop1, hop2, cross,
               forced, P(8), P(9), P(10), P(11), P(12));
    }
    free(u);
    free(k);
    return 0;
}
