/* The Krylov path's limit: one-step form of method B (Deuflhard: psi = sinc, phi = 1) on a chain of
 * n particles between fixed walls, A = 100 tridiag(-1, 2, -1) in CSR, U = sum (q_{i+1} - q_i)^4 / 4
 * + sum (1 - cos q_i), every product f(h sqrt(A)) v by the Lanczos method with the stopping rule of
 * trigint's core (the a posteriori estimate below tol twice in a row, or an invariant subspace),
 * the tridiagonal eigenproblem by the implicit QL method (tql2) at every Lanczos step.
 * Straight C, no BLAS: the same operations the core does, written plainly.
 *
 * Build: cc -O3 -march=native -o lanczos_limit lanczos_limit.c -lm
 * Usage: lanczos_limit N STEPS   (prints a checksum, then ms per step and us per Lanczos step) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define MAXIT 400
enum { OMC, CHI, PSI, POC, S2HC, CPOC, NF };

static int n;
static int *indptr, *indices;
static double *data, *basis, *w;
static double h, tol = 1e-12;
static long iterations, products;

static void matvec(const double *x, double *y) {
    for (int i = 0; i < n; i++) {
        double s = 0.0;
        for (int k = indptr[i]; k < indptr[i + 1]; k++) s += data[k] * x[indices[k]];
        y[i] = s;
    }
}

static double dot(const double *x, const double *y) {
    double p[8] = {0};
    int i = 0;
    for (; i + 8 <= n; i += 8)
        for (int t = 0; t < 8; t++) p[t] += x[i + t] * y[i + t];
    for (int t = 0; i < n; i++, t++) p[t] += x[i] * y[i];
    return ((p[0] + p[1]) + (p[2] + p[3])) + ((p[4] + p[5]) + (p[6] + p[7]));
}

/* eigenvalues d and eigenvectors z (k x k, row-major, column j = vector j) of the tridiagonal
 * matrix with diagonal d and off-diagonal e (e[k-1] = 0 on entry) */
static int tql2(int k, double *d, double *e, double *z) {
    memset(z, 0, sizeof(double) * k * k);
    for (int i = 0; i < k; i++) z[i * k + i] = 1.0;
    for (int l = 0; l < k; l++) {
        int sweeps = 0;
        for (;;) {
            int m = l;
            while (m + 1 < k && fabs(e[m]) > 2.220446049250313e-16 * (fabs(d[m]) + fabs(d[m + 1]))) m++;
            if (m == l) break;
            if (++sweeps > 60) return -1;
            double g = (d[l + 1] - d[l]) / (2.0 * e[l]);
            double r = hypot(g, 1.0);
            g = d[m] - d[l] + e[l] / (g + copysign(r, g));
            double s = 1.0, c = 1.0, p = 0.0;
            int i, deflated = 0;
            for (i = m - 1; i >= l; i--) {
                double f = s * e[i], b = c * e[i];
                r = hypot(f, g);
                e[i + 1] = r;
                if (r == 0.0) { d[i + 1] -= p; e[m] = 0.0; deflated = 1; break; }
                s = f / r; c = g / r;
                g = d[i + 1] - p;
                r = (d[i] - g) * s + 2.0 * c * b;
                p = s * r;
                d[i + 1] = g + p;
                g = c * r - b;
                for (int q = 0; q < k; q++) {
                    double t = z[q * k + i + 1];
                    z[q * k + i + 1] = s * z[q * k + i] + c * t;
                    z[q * k + i] = c * z[q * k + i] - s * t;
                }
            }
            if (deflated) continue;
            d[l] -= p; e[l] = g; e[m] = 0.0;
        }
    }
    return 0;
}

static void functions(double theta, double *f) {
    double xi = h * sqrt(theta > 0 ? theta : 0);
    if (xi == 0.0) { f[OMC] = 0; f[CHI] = f[PSI] = f[POC] = f[CPOC] = 1; f[S2HC] = 0; return; }
    double s = sin(xi), half = sin(0.5 * xi);
    f[OMC] = 2 * half * half;
    f[CHI] = s / xi;
    f[PSI] = f[CHI];
    f[POC] = f[PSI] / f[CHI];
    f[S2HC] = s * s / (h * f[CHI]);
    f[CPOC] = (1 - f[OMC]) * f[POC];
}

/* out[j] = f_which[j](h sqrt(A)) v */
static void apply(const double *v, int nf, const int *which, double **out) {
    static double alpha[MAXIT], beta[MAXIT], d[MAXIT], e[MAXIT], z[MAXIT * MAXIT], fv[MAXIT][NF], c[NF][MAXIT];
    products++;
    double beta0 = sqrt(dot(v, v));
    for (int i = 0; i < n; i++) basis[i] = v[i] / beta0;
    int previous = 0;
    for (int k = 0; k < MAXIT; k++) {
        iterations++;
        double *cur = basis + (size_t)k * n;
        matvec(cur, w);
        if (k > 0) {
            const double *last = cur - n;
            for (int i = 0; i < n; i++) w[i] -= beta[k - 1] * last[i];
        }
        alpha[k] = dot(cur, w);
        for (int i = 0; i < n; i++) w[i] -= alpha[k] * cur[i];
        double b = sqrt(dot(w, w));
        memcpy(d, alpha, sizeof(double) * (k + 1));
        memcpy(e, beta, sizeof(double) * k);
        e[k] = 0.0;
        if (tql2(k + 1, d, e, z)) { fprintf(stderr, "tql2 failed\n"); exit(1); }
        for (int j = 0; j <= k; j++) functions(d[j], fv[j]);
        int converged = 1;
        for (int f = 0; f < nf; f++) {
            double norm2 = 0.0;
            for (int i = 0; i <= k; i++) {
                double s = 0.0;
                for (int j = 0; j <= k; j++) s += z[i * (k + 1) + j] * (fv[j][which[f]] * z[j]);
                c[f][i] = s;
                norm2 += s * s;
            }
            double scale = fmax(sqrt(norm2), 1e-300);
            converged &= b * fabs(c[f][k]) <= tol * scale;
        }
        int invariant = b <= 1e-13 * fmax(fabs(alpha[k]), 1.0);
        if (invariant || (converged && previous)) {
            for (int f = 0; f < nf; f++) {
                double *o = out[f];
                memset(o, 0, sizeof(double) * n);
                for (int i = 0; i <= k; i++) {
                    const double *x = basis + (size_t)i * n;
                    for (int t = 0; t < n; t++) o[t] += c[f][i] * x[t];
                }
                for (int t = 0; t < n; t++) o[t] *= beta0;
            }
            return;
        }
        previous = converged;
        beta[k] = b;
        double *next = cur + n;
        for (int i = 0; i < n; i++) next[i] = w[i] / b;
    }
    fprintf(stderr, "no convergence\n");
    exit(1);
}

static void force(const double *q, double *g) {
    for (int i = 0; i < n; i++) g[i] = -sin(q[i]);
    for (int i = 0; i + 1 < n; i++) {
        double y = q[i + 1] - q[i], f = y * y * y;
        g[i] += f;
        g[i + 1] -= f;
    }
}

int main(int argc, char **argv) {
    if (argc != 3) { fprintf(stderr, "usage: lanczos_limit N STEPS\n"); return 2; }
    n = atoi(argv[1]);
    int steps = atoi(argv[2]);
    h = 0.05;
    indptr = malloc(sizeof(int) * (n + 1));
    indices = malloc(sizeof(int) * 3 * n);
    data = malloc(sizeof(double) * 3 * n);
    int nnz = 0;
    indptr[0] = 0;
    for (int i = 0; i < n; i++) {
        if (i > 0) { indices[nnz] = i - 1; data[nnz++] = -100.0; }
        indices[nnz] = i; data[nnz++] = 200.0;
        if (i + 1 < n) { indices[nnz] = i + 1; data[nnz++] = -100.0; }
        indptr[i + 1] = nnz;
    }
    basis = malloc(sizeof(double) * (size_t)n * (MAXIT + 1));
    w = malloc(sizeof(double) * n);
    double *q = malloc(sizeof(double) * n), *p = malloc(sizeof(double) * n), *qn = malloc(sizeof(double) * n),
           *pn = malloc(sizeof(double) * n), *g = malloc(sizeof(double) * n);
    double *gp[3], *gpn[3], *fq[2], *fp[2];
    for (int j = 0; j < 3; j++) { gp[j] = malloc(sizeof(double) * n); gpn[j] = malloc(sizeof(double) * n); }
    for (int j = 0; j < 2; j++) { fq[j] = malloc(sizeof(double) * n); fp[j] = malloc(sizeof(double) * n); }
    for (int i = 0; i < n; i++) {
        double x = (double)i / (n - 1);
        q[i] = 0.1 * sin(3 * M_PI * x);
        p[i] = sin(2 * M_PI * x);
    }
    const int gw[3] = {PSI, POC, CPOC}, qw[2] = {OMC, S2HC}, pw[2] = {OMC, CHI};
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    force(q, g);
    apply(g, 3, gw, gp);
    for (int s = 0; s < steps; s++) {
        apply(q, 2, qw, fq);
        apply(p, 2, pw, fp);
        for (int i = 0; i < n; i++) qn[i] = q[i] - fq[0][i] + h * fp[1][i] + 0.5 * h * h * gp[0][i];
        force(qn, g);
        apply(g, 3, gw, gpn);
        for (int i = 0; i < n; i++) pn[i] = p[i] - fp[0][i] - fq[1][i] + 0.5 * h * (gp[2][i] + gpn[1][i]);
        double *t;
        t = q; q = qn; qn = t;
        t = p; p = pn; pn = t;
        for (int j = 0; j < 3; j++) { t = gp[j]; gp[j] = gpn[j]; gpn[j] = t; }
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double sec = (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec);
    printf("check %.12g %.12g\n", q[n / 3], p[n / 2]);
    printf("%.6f %.4f %.3f\n", sec / steps * 1e3, sec / iterations * 1e6, (double)iterations / products);
    return 0;
}
