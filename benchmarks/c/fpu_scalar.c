/* A plain C loop of the recursion (trigo) for FPU with m = M springs, method B
 * (psi = sinc, phi = 1): the hardware reference for trigint's single-trajectory kernel.
 * The state lives in fixed-size local arrays that the compiler keeps in registers.
 * No energies are computed. Usage: fpu_scalar N_STEPS  ->  prints ns/step and a checksum. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#ifndef M
#define M 3
#endif
#define N (2 * M)

static void force(const double *x, double *f) {
    const double *x0 = x, *x1 = x + M;
    double *f0 = f, *f1 = f + M;
    for (int i = 0; i < N; i++) f[i] = 0.0;
    double d = x0[0] - x1[0], d3 = d * d * d;
    f0[0] -= d3; f1[0] += d3;
    for (int i = 1; i < M; i++) {
        d = x0[i] - x1[i] - x0[i - 1] - x1[i - 1]; d3 = d * d * d;
        f0[i] -= d3; f1[i] += d3; f0[i - 1] += d3; f1[i - 1] += d3;
    }
    d = x0[M - 1] + x1[M - 1]; d3 = d * d * d;
    f0[M - 1] -= d3; f1[M - 1] -= d3;
}

int main(int argc, char **argv) {
    long n_steps = argc > 1 ? atol(argv[1]) : 20000000L;
    double omega = 50.0, h = 2.0 * M_PI / 3.0 / omega;
    double two_c[N], h2psi[N], c[N], hsinc[N], q[N], qm[N], f[N], p0[N] = {0};
    for (int i = 0; i < N; i++) {
        double w = i < M ? 0.0 : omega, xi = h * w, s = xi == 0 ? 1.0 : sin(xi) / xi;
        c[i] = cos(xi); two_c[i] = 2.0 * c[i]; h2psi[i] = h * h * s; hsinc[i] = h * s;
        qm[i] = 0.0;
    }
    qm[0] = 1.0; p0[0] = 1.0; qm[M] = 1.0 / omega; p0[M] = 1.0;
    force(qm, f);
    for (int i = 0; i < N; i++) q[i] = c[i] * qm[i] + hsinc[i] * p0[i] + 0.5 * h2psi[i] * f[i];
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (long n = 1; n < n_steps; n++) {
        force(q, f);
        for (int i = 0; i < N; i++) {
            double next = two_c[i] * q[i] - qm[i] + h2psi[i] * f[i];
            qm[i] = q[i];
            q[i] = next;
        }
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double ns = (t1.tv_sec - t0.tv_sec) * 1e9 + (t1.tv_nsec - t0.tv_nsec);
    double checksum = 0;
    for (int i = 0; i < N; i++) checksum += q[i];
    printf("%.4f %.17g\n", ns / (double)(n_steps - 1), checksum);
    return 0;
}
