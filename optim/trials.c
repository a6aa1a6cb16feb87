/* A DE generation's arithmetic in C99: optim._jit.trials line for line (the same operations in the
 * same order: the numba path's and numpy's bits). Built by optim.native (no contraction into fused
 * multiply-adds, no fast-math); loaded by optim/_native.py. Arrays are C-contiguous; bool arrays
 * are numpy's one byte per element. */
#include <stdint.h>

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
