/*
 * Experiment (issue 29): what SIMD lanes buy on the hypersonic section 2.3 loop in plain C.
 *
 * The loop of hypersonic-direct-s1 (plant (2.50), 5x5 raw fuzzy basis, theta law (2.29), robust
 * term, two elevators; elevator 1 fails at a per-member onset to eff*u + bias), RK4 dt 1e-3 over
 * 120 s, no records, integrated two ways in the same run:
 *   scalar: one member after another (the shape of benchmarks/c/hypersonic_loop.c);
 *   lanes:  W members at once, struct-of-arrays state Y[27][W], every statement of the
 *           right-hand side a loop over the W lanes; each lane keeps its own time, step size and
 *           failure phase (its steps land on its own onset, as a single run's do).
 * Prints the time per member of both, their ratio, and the largest difference between a lane's
 * final state and its single run.
 *
 * Build and run (GCC; -DVEXP gives exp/sin/cos/tanh glibc's vector variants from libmvec):
 *   cc -O3 -march=native -fno-math-errno -fopenmp-simd -DVEXP -DW=16 -o lanes \
 *      hypersonic_lanes.c -lmvec -lm && ./lanes
 *
 * Measured on the 2-core znver4 machine (AVX-512, load 2-3, 7 rounds, fastest):
 *   without -DVEXP (scalar libm calls in the lane loops): lanes/scalar 0.96-1.06 (W = 4-16);
 *   with -DVEXP: W = 8 0.46, W = 16 0.39, W = 32 0.54; lanes within 1e-16 of their single runs
 *   (scale 0.08) after 120 s. So lanes pay only with a vector exp: numba here has no SVML, and
 *   GCC vectorises the rhs only in this statement-per-loop form (a per-lane body with inner
 *   loops is refused: "loop nest containing two or more consecutive inner loops").
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#ifndef W
#define W 16
#endif
#define NX 2
#define NMF 5
#define NR 25
#define NY 27
static const double P[10] = {113.5891, 5.33e-6, -6565.0, 6875.0, -1.0, 0.0026, -6.83, 0.303, -0.23, 0.0292};
static const double CEN[NMF] = {-1.25, -0.625, 0.0, 0.625, 1.25};
#define LAM 2.0
#define KK 5.0
#define K0 2.0
#define EPS0 0.01
#define GAM 5.0
#define SIG 0.01
#define AW (1.0 / (2.0 * 0.5))
#define RA (M_PI / 36.0)
#define RW 0.2
#ifdef VEXP
#pragma omp declare simd notinbranch
extern double tanh(double);
#pragma omp declare simd notinbranch
extern double exp(double);
#pragma omp declare simd notinbranch
extern double sin(double);
#pragma omp declare simd notinbranch
extern double cos(double);

#endif

/* per-lane failure: elevator 1 (index 0) becomes eff*u + bias after onset */
typedef struct { double onset, eff, bias; } Fail;

static inline void rhs1(double t, const double *Y, int failed, const Fail *f, double *dY) {
    double wt = RW * t, sn = sin(wt), cs = cos(wt);
    double r0 = RA * sn, r1 = RA * cs * RW, r2 = -RA * sn * RW * RW;
    double x0 = Y[0], x1 = Y[1];
    double e = r0 - x0, ed = r1 - x1, s = ed + LAM * e;
    double mu0[NMF], mu1[NMF], phi[NR];
    for (int l = 0; l < NMF; l++) {
        double d0 = x0 - CEN[l], d1 = x1 - CEN[l];
        mu0[l] = exp(-AW * d0 * d0);
        mu1[l] = exp(-AW * d1 * d1);
    }
    double u0 = 0.0;
    for (int i = 0; i < NMF; i++)
        for (int l = 0; l < NMF; l++) { double p = mu0[i] * mu1[l]; phi[i * NMF + l] = p; u0 += p * Y[NX + i * NMF + l]; }
    double u1 = 1.0 * u0, u2 = 2.0 * u0;
    double uf1 = failed ? f->eff * u1 + f->bias : u1;
    double usum = uf1 + u2;
    double xd1 = P[0] * (P[1] * (P[2] * x0 * x0 + P[3] * x0 + P[4]) + P[5] * x1 * (P[6] * x0 * x0 + P[7] * x0 + P[8]) + P[9] * (usum - x0));
    dY[0] = x1; dY[1] = xd1;
    double sd = r2 - xd1 + LAM * ed;
    double q = sd + KK * s + K0 * tanh(s / EPS0);
    for (int l = 0; l < NR; l++) dY[NX + l] = GAM * phi[l] * q - GAM * SIG * Y[NX + l];
}

static double run1(const Fail *f, double *yout) {
    double Y[NY], k1[NY], k2[NY], k3[NY], k4[NY], yt[NY];
    Y[0] = 0.03; Y[1] = 0.0; for (int l = 0; l < NR; l++) Y[NX + l] = 0.01;
    double brk[3] = {0.0, f->onset, 120.0};
    for (int ph = 0; ph < 2; ph++) {
        double a = brk[ph], b = brk[ph + 1];
        long n = (long)ceil((b - a) / 1e-3 - 1e-9); double h = (b - a) / n;
        for (long st = 0; st < n; st++) {
            double t = a + st * h, t1 = st == n - 1 ? b : a + (st + 1) * h, hh = t1 - t;
            rhs1(t, Y, ph, f, k1); for (int i = 0; i < NY; i++) yt[i] = Y[i] + 0.5 * hh * k1[i];
            rhs1(t + 0.5 * hh, yt, ph, f, k2); for (int i = 0; i < NY; i++) yt[i] = Y[i] + 0.5 * hh * k2[i];
            rhs1(t + 0.5 * hh, yt, ph, f, k3); for (int i = 0; i < NY; i++) yt[i] = Y[i] + hh * k3[i];
            rhs1(t1, yt, ph, f, k4);
            for (int i = 0; i < NY; i++) Y[i] = Y[i] + hh / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }
    memcpy(yout, Y, sizeof Y);
    return Y[0];
}

/* lanes, statement-per-loop style: every statement a loop over the W lanes */
#define L for (int w = 0; w < W; w++)
static inline void rhsW(const double *t, const double (*restrict Y)[W], const int *failed, const double *eff, const double *bias, double (*restrict dY)[W]) {
    double sn[W], cs[W], r0[W], r1[W], r2[W], e[W], ed[W], s[W], mu0[NMF][W], mu1[NMF][W], phi[NR][W], u0[W], usum[W], xd1[W], q[W], a0[W], a1[W];
    L { double wt = RW * t[w]; sn[w] = sin(wt); cs[w] = cos(wt); }
    L { r0[w] = RA * sn[w]; r1[w] = RA * cs[w] * RW; r2[w] = -RA * sn[w] * RW * RW; }
    L { e[w] = r0[w] - Y[0][w]; ed[w] = r1[w] - Y[1][w]; s[w] = ed[w] + LAM * e[w]; }
    for (int l = 0; l < NMF; l++) {
        L { double d0 = Y[0][w] - CEN[l]; a0[w] = -AW * d0 * d0; double d1 = Y[1][w] - CEN[l]; a1[w] = -AW * d1 * d1; }
        L mu0[l][w] = exp(a0[w]);
        L mu1[l][w] = exp(a1[w]);
    }
    L u0[w] = 0.0;
    for (int i = 0; i < NMF; i++)
        for (int l = 0; l < NMF; l++) { L { double p = mu0[i][w] * mu1[l][w]; phi[i * NMF + l][w] = p; u0[w] += p * Y[NX + i * NMF + l][w]; } }
    L { double u1 = 1.0 * u0[w], u2 = 2.0 * u0[w]; double uf1 = failed[w] ? eff[w] * u1 + bias[w] : u1; usum[w] = uf1 + u2; }
    L { double x0 = Y[0][w], x1 = Y[1][w]; xd1[w] = P[0] * (P[1] * (P[2] * x0 * x0 + P[3] * x0 + P[4]) + P[5] * x1 * (P[6] * x0 * x0 + P[7] * x0 + P[8]) + P[9] * (usum[w] - x0)); dY[0][w] = x1; dY[1][w] = xd1[w]; }
    L { a0[w] = s[w] / EPS0; }
    L { a1[w] = tanh(a0[w]); }
    L { double sd = r2[w] - xd1[w] + LAM * ed[w]; q[w] = sd + KK * s[w] + K0 * a1[w]; }
    for (int l = 0; l < NR; l++) { L dY[NX + l][w] = GAM * phi[l][w] * q[w] - GAM * SIG * Y[NX + l][w]; }
}

static void runW(const Fail *f, double (*yout)[NY]) {
    static double Y[NY][W], k1[NY][W], k2[NY][W], k3[NY][W], k4[NY][W], yt[NY][W];
    double t[W], th[W], t1[W], hh[W], a[W], b[W], h[W]; long st[W], n[W]; int ph[W], done[W], eff_ph[W];
    double eff[W], bias[W];
    for (int w = 0; w < W; w++) {
        Y[0][w] = 0.03; Y[1][w] = 0.0; for (int l = 0; l < NR; l++) Y[NX + l][w] = 0.01;
        ph[w] = 0; st[w] = 0; a[w] = 0.0; b[w] = f[w].onset; n[w] = (long)ceil((b[w] - a[w]) / 1e-3 - 1e-9); h[w] = (b[w] - a[w]) / n[w];
        done[w] = 0; eff[w] = f[w].eff; bias[w] = f[w].bias;
    }
    int alive = W;
    while (alive) {
        for (int w = 0; w < W; w++) {
            t[w] = a[w] + st[w] * h[w]; t1[w] = st[w] == n[w] - 1 ? b[w] : a[w] + (st[w] + 1) * h[w];
            hh[w] = t1[w] - t[w]; th[w] = t[w] + 0.5 * hh[w]; eff_ph[w] = ph[w];
        }
        rhsW(t, (const double (*)[W])Y, eff_ph, eff, bias, k1);
        for (int i = 0; i < NY; i++) for (int w = 0; w < W; w++) yt[i][w] = Y[i][w] + 0.5 * hh[w] * k1[i][w];
        rhsW(th, (const double (*)[W])yt, eff_ph, eff, bias, k2);
        for (int i = 0; i < NY; i++) for (int w = 0; w < W; w++) yt[i][w] = Y[i][w] + 0.5 * hh[w] * k2[i][w];
        rhsW(th, (const double (*)[W])yt, eff_ph, eff, bias, k3);
        for (int i = 0; i < NY; i++) for (int w = 0; w < W; w++) yt[i][w] = Y[i][w] + hh[w] * k3[i][w];
        rhsW(t1, (const double (*)[W])yt, eff_ph, eff, bias, k4);
        for (int i = 0; i < NY; i++) for (int w = 0; w < W; w++)
            if (!done[w]) Y[i][w] = Y[i][w] + hh[w] / 6.0 * (k1[i][w] + 2.0 * k2[i][w] + 2.0 * k3[i][w] + k4[i][w]);
        for (int w = 0; w < W; w++) {
            if (done[w]) continue;
            if (++st[w] == n[w]) {
                if (ph[w] == 0) { ph[w] = 1; a[w] = b[w]; b[w] = 120.0; n[w] = (long)ceil((b[w] - a[w]) / 1e-3 - 1e-9); h[w] = (b[w] - a[w]) / n[w]; st[w] = 0; }
                else { done[w] = 1; alive--; st[w] = n[w] - 1; for (int i = 0; i < NY; i++) yout[w][i] = Y[i][w]; }
            }
        }
    }
}

static double now(void) { struct timespec ts; clock_gettime(CLOCK_MONOTONIC, &ts); return ts.tv_sec + 1e-9 * ts.tv_nsec; }

int main(void) {
    Fail f[W]; srand(1);
    for (int w = 0; w < W; w++) { f[w].onset = 10.0 + 80.0 * rand() / RAND_MAX; f[w].onset = round(f[w].onset * 1000) / 1000; f[w].eff = 0.1 + 0.8 * rand() / RAND_MAX; f[w].bias = -0.1 + 0.2 * rand() / RAND_MAX; }
    double ys[W][NY], yl[W][NY];
    double best1 = 1e9, bestW = 1e9;
    for (int rep = 0; rep < 7; rep++) {
        double t0 = now(); for (int w = 0; w < W; w++) run1(&f[w], ys[w]); double d1 = (now() - t0) / W;
        t0 = now(); runW(f, yl); double dW = (now() - t0) / W;
        if (d1 < best1) best1 = d1;
        if (dW < bestW) bestW = dW;
    }
    double md = 0, sc = 0;
    for (int w = 0; w < W; w++) for (int i = 0; i < NY; i++) { double d = fabs(ys[w][i] - yl[w][i]); if (d > md) md = d; if (fabs(ys[w][i]) > sc) sc = fabs(ys[w][i]); }
    printf("W=%d per member: scalar %.2f ms, lanes %.2f ms, ratio %.3f, max diff %.3g (scale %.3g)\n", W, best1 * 1e3, bestW * 1e3, bestW / best1, md, sc);
    return 0;
}
