/* A hand-written structure-of-arrays C loop: B trajectories of FPU (m = M), method B, each
 * coordinate a separate non-aliasing array over the lanes of a block, so the compiler
 * vectorizes across trajectories. No energies. Usage: fpu_soa B N_STEPS -> ns per
 * trajectory-step and a checksum. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#ifndef M
#define M 3
#endif
#define N (2 * M)
#define BLOCK 256

static void block_steps(int lanes, long n_steps, double *restrict *q, double *restrict *qm,
                        const double *two_c, const double *h2psi) {
    double f[N][BLOCK];
    for (long n = 0; n < n_steps; n++) {
        for (int i = 0; i < N; i++)
            for (int b = 0; b < lanes; b++) f[i][b] = 0.0;
        for (int b = 0; b < lanes; b++) {
            double d = q[0][b] - q[M][b], d3 = d * d * d;
            f[0][b] -= d3; f[M][b] += d3;
        }
        for (int i = 1; i < M; i++)
            for (int b = 0; b < lanes; b++) {
                double d = q[i][b] - q[M + i][b] - q[i - 1][b] - q[M + i - 1][b], d3 = d * d * d;
                f[i][b] -= d3; f[M + i][b] += d3; f[i - 1][b] += d3; f[M + i - 1][b] += d3;
            }
        for (int b = 0; b < lanes; b++) {
            double d = q[M - 1][b] + q[N - 1][b], d3 = d * d * d;
            f[M - 1][b] -= d3; f[N - 1][b] -= d3;
        }
        for (int i = 0; i < N; i++) {
            double *restrict qi = q[i], *restrict qmi = qm[i];
            for (int b = 0; b < lanes; b++) {
                double next = two_c[i] * qi[b] - qmi[b] + h2psi[i] * f[i][b];
                qmi[b] = qi[b];
                qi[b] = next;
            }
        }
    }
}

int main(int argc, char **argv) {
    int count = argc > 1 ? atoi(argv[1]) : 1000;
    long n_steps = argc > 2 ? atol(argv[2]) : 200000L;
    double omega = 50.0, h = 2.0 * M_PI / 3.0 / omega, two_c[N], h2psi[N];
    for (int i = 0; i < N; i++) {
        double xi = i < M ? 0.0 : h * omega, s = xi == 0 ? 1.0 : sin(xi) / xi;
        two_c[i] = 2.0 * cos(xi); h2psi[i] = h * h * s;
    }
    double checksum = 0, ns = 0;
    for (int start = 0; start < count; start += BLOCK) {
        int lanes = count - start < BLOCK ? count - start : BLOCK;
        double *q[N], *qm[N];
        for (int i = 0; i < N; i++) {
            q[i] = aligned_alloc(64, BLOCK * sizeof(double));
            qm[i] = aligned_alloc(64, BLOCK * sizeof(double));
            for (int b = 0; b < BLOCK; b++) q[i][b] = qm[i][b] = 0.0;
        }
        for (int b = 0; b < lanes; b++) {
            qm[0][b] = 1.0 + 1e-3 * (start + b); qm[M][b] = 1.0 / omega;
            q[0][b] = qm[0][b] + h; q[M][b] = qm[M][b] + h;  /* a first step; any start will do */
        }
        struct timespec t0, t1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        block_steps(lanes, n_steps, q, qm, two_c, h2psi);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        ns += (t1.tv_sec - t0.tv_sec) * 1e9 + (t1.tv_nsec - t0.tv_nsec);
        for (int b = 0; b < lanes; b++) checksum += q[0][b];
        for (int i = 0; i < N; i++) { free(q[i]); free(qm[i]); }
    }
    printf("%.4f %.17g\n", ns / ((double)count * n_steps), checksum);
    return 0;
}
