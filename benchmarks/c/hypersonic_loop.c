/*
 * Plain C reference of the hypersonic section 2.3 closed loop (thesis eq. (2.50) plant, direct
 * adaptive design (2.22)/(2.29) with a 5x5 raw fuzzy basis on (alpha, q), proportional
 * allocation (2.10)), integrated exactly as adaptive_ftc's fixed-step RK4 path does it:
 * steps land on every failure onset/recovery, states are recorded on the record_dt grid (exact
 * copy at a step end, cubic Hermite otherwise) and the recorded signals are recomputed after
 * the run. Used by benchmarks/bench_engine.py, benchmarks/bench_batch.py and tests/test_cref.py
 * as the speed limit and as an independent check of the trajectory.
 *
 * Build: cc -O3 -march=native -o hypersonic_loop hypersonic_loop.c -lm -pthread
 *
 * Usage:
 *   hypersonic_loop single [--mode whole|integrate] [--repeat R] [--t-final T] [--dt DT]
 *                          [--record-dt RDT] [--failures FILE] [--out FILE]
 *       One run of scenario hypersonic-direct-s1 (its failures unless --failures gives others),
 *       repeated R times. Prints "elapsed <s>" per repetition (wall time of the work only),
 *       then "status", "nrec" and the final alpha. --out writes the last repetition as binary
 *       float64: header [nrec, n_state, n_signal, status] then time (nrec), states
 *       (nrec x 27) and, in mode whole, the signals (nrec x 17, columns as in
 *       adaptive_ftc.sim.kernel.signals).
 *   hypersonic_loop batch --runs FILE [--threads N] [--t-final T] [--dt DT] [--record-dt RDT]
 *                         [--out FILE]
 *       Many runs on N pthreads (whole runs: integration, recording and signals). Prints
 *       "elapsed <s>" and "runs <n>". --out writes float64 rows [status, nrec, final state(27)].
 *
 * Failure files (text, whitespace separated):
 *   --failures: "nf" then nf records "actuator kind onset recovery p0 p1 p2 p3"
 *   --runs:     "n_runs" then per run "alpha0 q0 nf" followed by nf such records
 *   actuator counts from 1; recovery "inf" for none; kinds (u is the command):
 *     0 loss of effectiveness  p0*u          1 bias    u + p0
 *     2 stuck                  p0            3 affine  p0*u + p1
 *     4 oscillating stuck      p0 + p1*cos(p2*t) - p3*sin(p2*t)   (scenario 1, elevator 2)
 */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define NX 2        /* plant states alpha, q */
#define NM 2        /* elevators */
#define NMF 5       /* memberships per input */
#define NR (NMF * NMF)  /* fuzzy rules */
#define NY (NX + NR)    /* closed-loop states */
#define NSIG 17     /* recorded signal columns */
#define MAXF 16     /* failures per run */
#define MAXB (2 * MAXF + 2)

enum { F_LOE = 0, F_BIAS = 1, F_STUCK = 2, F_AFFINE = 3, F_OSC = 4 };

typedef struct {
    int act;  /* 0-based */
    int kind;
    double onset, recovery;
    double p[4];
} Failure;

typedef struct {
    /* plant (2.50): scale, k_alpha, alpha_poly(3), k_q, q_poly(3), k_elevator */
    double P[10];
    double b[NM];
    double lam, k, k0, eps0, gamma, sigma, theta0;
    double cen[2][NMF];
    double aw; /* 1 / (2 w^2) */
    double ref_amp, ref_w; /* y_d = amp sin(w t) */
    double x0[NX];
    double t0, tf, dt, rdt, bound;
    int nf;
    Failure f[MAXF];
} Loop;

typedef struct {
    int nph;
    double brk[MAXB];
    int act[MAXB][NM]; /* failure index acting on each actuator per phase, -1 healthy */
} Phases;

typedef struct {
    double phi[NR];
    double u0, u[NM], uf[NM], xdot[NX];
    double ref[3], ref_t;
    int ref_valid;
    double e, ed, s, sd, q;
} Work;

/* ------------------------------------------------------------------ scenario hypersonic-direct-s1 */
static void default_loop(Loop *L) {
    static const double P[10] = {113.5891, 5.33e-6, -6565.0, 6875.0, -1.0,
                                 0.0026,   -6.83,   0.303,   -0.23,  0.0292};
    static const double c[NMF] = {-1.25, -0.625, 0.0, 0.625, 1.25};
    memset(L, 0, sizeof *L);
    memcpy(L->P, P, sizeof P);
    L->b[0] = 1.0;
    L->b[1] = 2.0;
    L->lam = 2.0;
    L->k = 5.0;
    L->k0 = 2.0;
    L->eps0 = 0.01;
    L->gamma = 5.0;
    L->sigma = 0.01;
    L->theta0 = 0.01;
    for (int i = 0; i < 2; i++)
        for (int l = 0; l < NMF; l++) L->cen[i][l] = c[l];
    double w = 0.7071067811865476;
    L->aw = 1.0 / (2.0 * (w * w));
    L->ref_amp = M_PI / 36.0;
    L->ref_w = 0.2;
    L->x0[0] = 0.03;
    L->x0[1] = 0.0;
    L->t0 = 0.0;
    L->tf = 120.0;
    L->dt = 1e-3;
    L->rdt = 0.01;
    L->bound = 1e8;
    L->nf = 2;
    L->f[0] = (Failure){1, F_OSC, 40.0, INFINITY, {0.1, 0.05, 0.5, 0.08}};
    L->f[1] = (Failure){0, F_AFFINE, 80.0, INFINITY, {0.75, -0.2, 0.0, 0.0}};
}

/* ------------------------------------------------------------------ failure patterns */
static inline double fail_out(const Failure *f, double t, double u) {
    switch (f->kind) {
    case F_LOE: return f->p[0] * u;
    case F_BIAS: return u + f->p[0];
    case F_STUCK: return f->p[0];
    case F_AFFINE: return f->p[0] * u + f->p[1];
    default: return f->p[0] + f->p[1] * cos(f->p[2] * t) - f->p[3] * sin(f->p[2] * t);
    }
}

/* d u^f / d u */
static inline double fail_du(const Failure *f) {
    switch (f->kind) {
    case F_LOE: case F_AFFINE: return f->p[0];
    case F_BIAS: return 1.0;
    default: return 0.0;
    }
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* intervals of fixed failure pattern (FailureSchedule.breakpoints / active) */
static void make_phases(const Loop *L, Phases *ph) {
    double t[MAXB];
    int n = 0;
    t[n++] = L->t0;
    t[n++] = L->tf;
    for (int i = 0; i < L->nf; i++) {
        double a = L->f[i].onset, r = L->f[i].recovery;
        if (a > L->t0 && a < L->tf) t[n++] = a;
        if (isfinite(r) && r > L->t0 && r < L->tf) t[n++] = r;
    }
    qsort(t, n, sizeof(double), cmp_double);
    int m = 0;
    for (int i = 0; i < n; i++)
        if (m == 0 || t[i] != t[m - 1]) t[m++] = t[i];
    ph->nph = m - 1;
    for (int i = 0; i < m; i++) ph->brk[i] = t[i];
    for (int k = 0; k < ph->nph; k++) {
        double mid = 0.5 * (t[k] + t[k + 1]);
        for (int j = 0; j < NM; j++) ph->act[k][j] = -1;
        for (int i = 0; i < L->nf; i++)
            if (L->f[i].onset <= mid && mid < L->f[i].recovery) ph->act[k][L->f[i].act] = i;
    }
}

/* ------------------------------------------------------------------ closed loop */
static inline void plant(const double *P, const double *x, double usum, double *xdot) {
    double a = x[0], q = x[1];
    xdot[0] = q;
    xdot[1] = P[0] * (P[1] * (P[2] * a * a + P[3] * a + P[4]) + P[5] * q * (P[6] * a * a + P[7] * a + P[8]) +
                      P[9] * (usum - a));
}

static inline void closed_loop(const Loop *L, const Phases *ph, int k, double t, const double *Y,
                               Work *W, double *dY) {
    const double *x = Y;
    const double *th = Y + NX;
    if (!(W->ref_valid && W->ref_t == t)) {
        double wt = L->ref_w * t, sn = sin(wt), cs = cos(wt);
        W->ref[0] = L->ref_amp * sn;
        W->ref[1] = L->ref_amp * cs * L->ref_w;
        W->ref[2] = L->ref_amp * (-sn) * L->ref_w * L->ref_w;
        W->ref_t = t;
        W->ref_valid = 1;
    }
    W->e = W->ref[0] - x[0];
    W->ed = W->ref[1] - x[1];
    W->s = W->ed + L->lam * W->e;
    /* raw fuzzy firing strengths, last input fastest */
    double mu0[NMF], mu1[NMF];
    for (int l = 0; l < NMF; l++) {
        double d0 = x[0] - L->cen[0][l], d1 = x[1] - L->cen[1][l];
        mu0[l] = exp(-L->aw * d0 * d0);
        mu1[l] = exp(-L->aw * d1 * d1);
    }
    double u0 = 0.0;
    for (int i = 0; i < NMF; i++)
        for (int l = 0; l < NMF; l++) {
            double p = mu0[i] * mu1[l];
            W->phi[i * NMF + l] = p;
            u0 += p * th[i * NMF + l];
        }
    W->u0 = u0;
    double usum = 0.0;
    for (int j = 0; j < NM; j++) {
        double u = L->b[j] * u0;
        int fi = ph->act[k][j];
        W->u[j] = u;
        W->uf[j] = fi < 0 ? u : fail_out(&L->f[fi], t, u);
        usum += W->uf[j];
    }
    plant(L->P, x, usum, W->xdot);
    dY[0] = W->xdot[0];
    dY[1] = W->xdot[1];
    W->sd = W->ref[2] - W->xdot[1] + L->lam * W->ed;
    W->q = W->sd + L->k * W->s + L->k0 * tanh(W->s / L->eps0);
    double gs = L->gamma * L->sigma;
    for (int l = 0; l < NR; l++) dY[NX + l] = L->gamma * W->phi[l] * W->q - gs * th[l];
}

static inline int check(const double *Y, double bound) {
    for (int i = 0; i < NY; i++)
        if (!(fabs(Y[i]) < bound)) return i;
    return -1;
}

static int record_times(const Loop *L, double **out) {
    int n = (int)floor((L->tf - L->t0) / L->rdt + 1e-9);
    double last = L->t0 + L->rdt * n;
    int extra = (L->tf - last > 1e-9 * fmax(1.0, fabs(L->tf))) ? 1 : 0;
    double *t = malloc(sizeof(double) * (n + 1 + extra));
    for (int i = 0; i <= n; i++) t[i] = L->t0 + L->rdt * (double)i;
    if (extra) t[n + 1] = L->tf;
    *out = t;
    return n + 1 + extra;
}

/* RK4 with steps landing on every break (adaptive_ftc.sim.kernel.integrate_rk4).
 * Returns the number of recorded samples; *status 0 finished, 1 diverged. */
static int integrate(const Loop *L, const Phases *ph, const double *trec, int nrec, double *outY,
                     int *outph, int *status) {
    Work W = {0};
    W.ref_valid = 0;
    double Y[NY], k1[NY], k2[NY], k3[NY], k4[NY], yt[NY], yn[NY], fe[NY];
    Y[0] = L->x0[0];
    Y[1] = L->x0[1];
    for (int l = 0; l < NR; l++) Y[NX + l] = L->theta0;
    int r = 0, nph = ph->nph;
    double t_end = ph->brk[nph];
    *status = 0;
    if (check(Y, L->bound) >= 0) {
        *status = 1;
        return 0;
    }
    for (int k = 0; k < nph; k++) {
        double a = ph->brk[k], b = ph->brk[k + 1];
        double tol = 1e-9 * fmax(1.0, fabs(b));
        long nsteps = (long)ceil((b - a) / L->dt - 1e-9);
        if (nsteps < 1) nsteps = 1;
        double h = (b - a) / nsteps;
        while (r < nrec && trec[r] <= a + tol) {
            memcpy(outY + (size_t)r * NY, Y, sizeof Y);
            outph[r++] = k;
        }
        for (long st = 0; st < nsteps; st++) {
            double t = a + st * h;
            double t1 = st == nsteps - 1 ? b : a + (st + 1) * h;
            double hh = t1 - t, h2 = 0.5 * hh, h6 = hh / 6.0;
            closed_loop(L, ph, k, t, Y, &W, k1);
            for (int i = 0; i < NY; i++) yt[i] = Y[i] + h2 * k1[i];
            closed_loop(L, ph, k, t + h2, yt, &W, k2);
            for (int i = 0; i < NY; i++) yt[i] = Y[i] + h2 * k2[i];
            closed_loop(L, ph, k, t + h2, yt, &W, k3);
            for (int i = 0; i < NY; i++) yt[i] = Y[i] + hh * k3[i];
            closed_loop(L, ph, k, t1, yt, &W, k4);
            for (int i = 0; i < NY; i++) yn[i] = Y[i] + h6 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            if (check(yn, L->bound) >= 0) {
                *status = 1;
                return r;
            }
            int last = (k == nph - 1) && (st == nsteps - 1);
            double limit = last ? t1 + tol : t1 - tol;
            int have_end = 0;
            while (r < nrec && trec[r] < limit) {
                double tr = trec[r];
                double *o = outY + (size_t)r * NY;
                if (fabs(tr - t1) <= tol) {
                    memcpy(o, yn, sizeof yn);
                } else {
                    if (!have_end) {
                        closed_loop(L, ph, k, t1, yn, &W, fe);
                        have_end = 1;
                    }
                    double s = (tr - t) / hh, s2 = s * s, s3 = s2 * s;
                    double h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + s;
                    double h01 = -2 * s3 + 3 * s2, h11 = s3 - s2;
                    for (int i = 0; i < NY; i++)
                        o[i] = h00 * Y[i] + h10 * hh * k1[i] + h01 * yn[i] + h11 * hh * fe[i];
                }
                outph[r++] = k;
            }
            memcpy(Y, yn, sizeof Y);
        }
    }
    while (r < nrec && trec[r] <= t_end + 1e-9 * fmax(1.0, fabs(t_end))) {
        memcpy(outY + (size_t)r * NY, Y, sizeof Y);
        outph[r++] = nph - 1;
    }
    return r;
}

/* recorded signals (adaptive_ftc.sim.kernel.signals): y, yd, yd_dot, e, edot, s, sdot, q, u0,
 * u(2), uf(2), uf_comp, gain, control_gain, sdot_used */
static void signals(const Loop *L, const Phases *ph, const double *T, const double *Ys,
                    const int *phs, int n, double *out) {
    Work W = {0};
    W.ref_valid = 0;
    double dY[NY], x0dot[NX], x1dot[NX];
    for (int r = 0; r < n; r++) {
        const double *Y = Ys + (size_t)r * NY;
        double t = T[r];
        int k = phs[r];
        closed_loop(L, ph, k, t, Y, &W, dY);
        double *o = out + (size_t)r * NSIG;
        o[0] = Y[0];
        o[1] = W.ref[0];
        o[2] = W.ref[1];
        o[3] = W.e;
        o[4] = W.ed;
        o[5] = W.s;
        o[6] = W.sd;
        o[7] = W.q;
        o[8] = W.u0;
        o[9] = W.u[0];
        o[10] = W.u[1];
        o[11] = W.uf[0];
        o[12] = W.uf[1];
        o[13] = 0.0;
        o[14] = 1.0;
        plant(L->P, Y, 0.0, x0dot);
        double gain = 0.0;
        for (int j = 0; j < NM; j++) {
            plant(L->P, Y, 1.0, x1dot);
            int fi = ph->act[k][j];
            double df = fi < 0 ? 1.0 : fail_du(&L->f[fi]);
            gain += (x1dot[1] - x0dot[1]) * L->b[j] * df;
        }
        o[15] = gain;
        o[16] = W.sd;
    }
}

typedef struct {
    int status, nrec;
    double *T, *Y, *S;
    int *ph;
} Run;

/* one whole run (whole = 1: with signals); buffers allocated per run as a library would */
static void run_one(const Loop *L, int whole, Run *R) {
    Phases ph;
    make_phases(L, &ph);
    int nt = record_times(L, &R->T);
    R->Y = malloc(sizeof(double) * (size_t)nt * NY);
    R->ph = malloc(sizeof(int) * (size_t)nt);
    R->nrec = integrate(L, &ph, R->T, nt, R->Y, R->ph, &R->status);
    R->S = NULL;
    if (whole) {
        R->S = malloc(sizeof(double) * (size_t)(R->nrec > 0 ? R->nrec : 1) * NSIG);
        signals(L, &ph, R->T, R->Y, R->ph, R->nrec, R->S);
    }
}

static void run_free(Run *R) {
    free(R->T);
    free(R->Y);
    free(R->ph);
    free(R->S);
}

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static void die(const char *msg, const char *arg) {
    fprintf(stderr, "hypersonic_loop: %s%s\n", msg, arg ? arg : "");
    exit(2);
}

static void read_failure(FILE *fp, Failure *f) {
    int act, kind;
    if (fscanf(fp, "%d %d %lf %lf %lf %lf %lf %lf", &act, &kind, &f->onset, &f->recovery, &f->p[0],
               &f->p[1], &f->p[2], &f->p[3]) != 8)
        die("malformed failure record", NULL);
    if (act < 1 || act > NM || kind < 0 || kind > F_OSC) die("bad actuator or failure kind", NULL);
    f->act = act - 1;
    f->kind = kind;
}

/* ------------------------------------------------------------------ batch on pthreads */
typedef struct {
    const Loop *loops;
    int n, next;
    pthread_mutex_t lock;
    double *out; /* n x (2 + NY) */
} Batch;

static void *worker(void *arg) {
    Batch *B = arg;
    for (;;) {
        pthread_mutex_lock(&B->lock);
        int i = B->next++;
        pthread_mutex_unlock(&B->lock);
        if (i >= B->n) return NULL;
        Run R;
        run_one(&B->loops[i], 1, &R);
        double *o = B->out + (size_t)i * (2 + NY);
        o[0] = R.status;
        o[1] = R.nrec;
        for (int j = 0; j < NY; j++) o[2 + j] = R.nrec > 0 ? R.Y[(size_t)(R.nrec - 1) * NY + j] : NAN;
        run_free(&R);
    }
}

int main(int argc, char **argv) {
    if (argc < 2 || (strcmp(argv[1], "single") && strcmp(argv[1], "batch")))
        die("usage: hypersonic_loop single|batch [options] (see the header of hypersonic_loop.c)", NULL);
    int batch = !strcmp(argv[1], "batch");
    Loop L;
    default_loop(&L);
    int repeat = 1, threads = 2, whole = 1;
    const char *out = NULL, *ffile = NULL, *rfile = NULL;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i];
        if (i + 1 >= argc) die("missing value after ", a);
        const char *v = argv[++i];
        if (!strcmp(a, "--mode")) {
            if (!strcmp(v, "whole")) whole = 1;
            else if (!strcmp(v, "integrate")) whole = 0;
            else die("--mode must be whole or integrate, got ", v);
        } else if (!strcmp(a, "--repeat")) repeat = atoi(v);
        else if (!strcmp(a, "--threads")) threads = atoi(v);
        else if (!strcmp(a, "--t-final")) L.tf = atof(v);
        else if (!strcmp(a, "--dt")) L.dt = atof(v);
        else if (!strcmp(a, "--record-dt")) L.rdt = atof(v);
        else if (!strcmp(a, "--failures")) ffile = v;
        else if (!strcmp(a, "--runs")) rfile = v;
        else if (!strcmp(a, "--out")) out = v;
        else die("unknown option ", a);
    }
    if (repeat < 1 || threads < 1 || !(L.tf > L.t0) || !(L.dt > 0) || !(L.rdt > 0))
        die("--repeat, --threads, --t-final, --dt and --record-dt must be positive", NULL);
    if (!batch) {
        if (ffile) {
            FILE *fp = fopen(ffile, "r");
            if (!fp) die("cannot open ", ffile);
            if (fscanf(fp, "%d", &L.nf) != 1 || L.nf < 0 || L.nf > MAXF) die("bad failure count in ", ffile);
            for (int i = 0; i < L.nf; i++) read_failure(fp, &L.f[i]);
            fclose(fp);
        }
        Run R = {0};
        for (int k = 0; k < repeat; k++) {
            if (k) run_free(&R);
            double t = now();
            run_one(&L, whole, &R);
            printf("elapsed %.9f\n", now() - t);
        }
        printf("status %d\nnrec %d\nalpha_final %.17g\n", R.status, R.nrec,
               R.nrec ? R.Y[(size_t)(R.nrec - 1) * NY] : NAN);
        if (out) {
            FILE *fp = fopen(out, "wb");
            if (!fp) die("cannot write ", out);
            double hdr[4] = {R.nrec, NY, whole ? NSIG : 0, R.status};
            fwrite(hdr, sizeof(double), 4, fp);
            fwrite(R.T, sizeof(double), R.nrec, fp);
            fwrite(R.Y, sizeof(double), (size_t)R.nrec * NY, fp);
            if (whole) fwrite(R.S, sizeof(double), (size_t)R.nrec * NSIG, fp);
            fclose(fp);
        }
        run_free(&R);
        return 0;
    }
    if (!rfile) die("batch needs --runs FILE", NULL);
    FILE *fp = fopen(rfile, "r");
    if (!fp) die("cannot open ", rfile);
    int n;
    if (fscanf(fp, "%d", &n) != 1 || n < 1) die("bad run count in ", rfile);
    Loop *loops = malloc(sizeof(Loop) * (size_t)n);
    for (int i = 0; i < n; i++) {
        loops[i] = L;
        if (fscanf(fp, "%lf %lf %d", &loops[i].x0[0], &loops[i].x0[1], &loops[i].nf) != 3 ||
            loops[i].nf < 0 || loops[i].nf > MAXF)
            die("malformed run record in ", rfile);
        for (int j = 0; j < loops[i].nf; j++) read_failure(fp, &loops[i].f[j]);
    }
    fclose(fp);
    Batch B = {loops, n, 0, PTHREAD_MUTEX_INITIALIZER, malloc(sizeof(double) * (size_t)n * (2 + NY))};
    pthread_t *tid = malloc(sizeof(pthread_t) * (size_t)threads);
    double t = now();
    for (int k = 0; k < threads; k++) pthread_create(&tid[k], NULL, worker, &B);
    for (int k = 0; k < threads; k++) pthread_join(tid[k], NULL);
    printf("elapsed %.9f\nruns %d\n", now() - t, n);
    if (out) {
        FILE *fo = fopen(out, "wb");
        if (!fo) die("cannot write ", out);
        fwrite(B.out, sizeof(double), (size_t)n * (2 + NY), fo);
        fclose(fo);
    }
    free(B.out);
    free(tid);
    free(loops);
    return 0;
}
