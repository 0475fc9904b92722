/*
 * Dormand-Prince 5(4) with step-size control and dense output (after Hairer's dopri5,
 * Hairer, Norsett & Wanner, Solving ODEs I, Sec. II.5 and II.6), for Hamiltonian
 * flows whose right-hand side switches between smooth branches ("modes") where a
 * switching function changes sign (Martinon & Gergaud, 2009).
 *
 * Switching treatment (opt_int[I_DETECT]):
 *   0 none        the mode is re-evaluated at every stage; the adaptive integrator copes;
 *   1 detection   the mode is frozen during a step; on a sign change at the step's end the
 *                 zero is located on the dense output, the mode switched, and the
 *                 integration restarted from there;
 *   2 correction  as detection, then g(y(tau)) = 0 is solved with y(tau) given by an
 *                 actual Dormand-Prince step from the step's start (the dense-output
 *                 zero is the starting guess), and the integration restarts from tau.
 *
 * Crossings inside a step (opt_int[I_INTERIOR], detection and correction only): a sign
 * test at the step's ends misses a pair of crossings within one step, i.e. a short arc
 * (Shampine & Thompson, "Event location for ordinary differential equations", 2000), and
 * may locate the last of three crossings rather than the first. With the check on, g's
 * cubic Hermite interpolant from g and dg/dt = dg/dy . f at both ends says where g has an
 * interior extremum; where the cubic comes near or through zero there, g is evaluated on
 * the dense output, and a sign change there puts the first crossing before it (located on
 * the dense output, and by the correction within that bracket). A heuristic: an excursion
 * the cubic does not foresee is still missed.
 *
 * With variational columns (opt_int[I_NVAR] > 0) the state is augmented by
 * Psi = dy/dz (n x nvar, column-major), integrated on the same steps (error control on y
 * only), with the jump at a switching from branch I to II at tau
 *     Psi(tau+) = Psi(tau-) + (phi_I(y_tau) - phi_II(y_tau)) tau'(z),
 *     tau'(z) = -(dg/dy Psi(tau-)) / (dg/dy phi_I(y_tau)).
 *
 * The flows come from CasADi-generated C (ocp_flow, ocp_varflow, ocp_switching,
 * ocp_dswitch, ocp_ham), compiled into the same shared library.
 */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef long long casadi_int;
typedef double casadi_real;

#define DECLARE(name)                                                                          \
    int name(const casadi_real **arg, casadi_real **res, casadi_int *iw, casadi_real *w, int mem); \
    int name##_work(casadi_int *sz_arg, casadi_int *sz_res, casadi_int *sz_iw, casadi_int *sz_w);
DECLARE(ocp_flow)
DECLARE(ocp_varflow)
DECLARE(ocp_switching)
DECLARE(ocp_dswitch)
DECLARE(ocp_ham)

/* integer options */
enum { I_N, I_NVAR, I_NG, I_NGROUPS, I_DETECT, I_MAXSTEPS, I_RECORD, I_CAP, I_INTERIOR, I_NOPT };
/* real options */
enum { D_RTOL, D_ATOL, D_H0, D_HMAX, D_NOPT };
/* integer outputs */
enum { O_STATUS, O_ACCEPTED, O_REJECTED, O_NFEV, O_SWITCHES, O_NHIST, O_NREJ, O_NSW, O_INTERIOR, O_NOUT };
/* status codes */
enum { OK = 0, MAX_STEPS = 1, STEP_TOO_SMALL = 2, NOT_FINITE = 3, NO_MEMORY = 4, BAD_ROOT = 5 };

/* Dormand-Prince coefficients */
static const double c2 = 0.2, c3 = 0.3, c4 = 0.8, c5 = 8.0 / 9.0;
static const double a21 = 0.2;
static const double a31 = 3.0 / 40.0, a32 = 9.0 / 40.0;
static const double a41 = 44.0 / 45.0, a42 = -56.0 / 15.0, a43 = 32.0 / 9.0;
static const double a51 = 19372.0 / 6561.0, a52 = -25360.0 / 2187.0, a53 = 64448.0 / 6561.0,
                    a54 = -212.0 / 729.0;
static const double a61 = 9017.0 / 3168.0, a62 = -355.0 / 33.0, a63 = 46732.0 / 5247.0,
                    a64 = 49.0 / 176.0, a65 = -5103.0 / 18656.0;
static const double a71 = 35.0 / 384.0, a73 = 500.0 / 1113.0, a74 = 125.0 / 192.0,
                    a75 = -2187.0 / 6784.0, a76 = 11.0 / 84.0;
static const double e1 = 71.0 / 57600.0, e3 = -71.0 / 16695.0, e4 = 71.0 / 1920.0,
                    e5 = -17253.0 / 339200.0, e6 = 22.0 / 525.0, e7 = -1.0 / 40.0;
static const double d1 = -12715105075.0 / 11282082432.0, d3 = 87487479700.0 / 32700410799.0,
                    d4 = -10690763975.0 / 1880347072.0, d5 = 701980252875.0 / 199316789632.0,
                    d6 = -1453857185.0 / 822651844.0, d7 = 69997945.0 / 29380423.0;

typedef struct {
    int n, nvar, N, ng, ngroups, detect;
    const int *group_sizes;
    const double *P;
    double rtol, atol;
    long nfev;
    /* CasADi work */
    const casadi_real **arg;
    casadi_real **res;
    casadi_int *iw;
    casadi_real *w;
    /* scratch */
    double *g, *gtmp, *dg, *phiI, *phiII, *ytmp;
    double *k1, *k2, *k3, *k4, *k5, *k6, *k7, *y1, *ysti, *cont;
} Ctx;

static void work_max(int (*fw)(casadi_int *, casadi_int *, casadi_int *, casadi_int *), casadi_int *m) {
    casadi_int a, r, i, w;
    fw(&a, &r, &i, &w);
    if (a > m[0]) m[0] = a;
    if (r > m[1]) m[1] = r;
    if (i > m[2]) m[2] = i;
    if (w > m[3]) m[3] = w;
}

/* branch flow phi_mode(y) (base state only) */
static void flow(Ctx *c, const double *y, int mode, double *dy) {
    double md = (double)mode;
    c->arg[0] = y; c->arg[1] = &md; c->arg[2] = c->P;
    c->res[0] = dy;
    ocp_flow(c->arg, c->res, c->iw, c->w, 0);
    c->nfev++;
}

static void switching(Ctx *c, const double *y, double *g) {
    c->arg[0] = y; c->arg[1] = c->P;
    c->res[0] = g;
    ocp_switching(c->arg, c->res, c->iw, c->w, 0);
}

static int mode_from_signs(const Ctx *c, const int *signs) {
    int mode = 0, stride = 1, k = 0;
    for (int j = 0; j < c->ngroups; j++) {
        int regime = 0;
        for (int t = 0; t < c->group_sizes[j]; t++) regime += signs[k + t];
        mode += regime * stride;
        stride *= c->group_sizes[j] + 1;
        k += c->group_sizes[j];
    }
    return mode;
}

static void signs_of(const Ctx *c, const double *g, int *signs) {
    for (int k = 0; k < c->ng; k++) signs[k] = g[k] > 0.0;
}

/* right-hand side of the (augmented) system; mode < 0: decided by the switching functions here */
static int rhs(Ctx *c, const double *Y, int mode, double *dY, int *signs_scratch) {
    if (mode < 0) {
        switching(c, Y, c->gtmp);
        signs_of(c, c->gtmp, signs_scratch);
        mode = mode_from_signs(c, signs_scratch);
    }
    double md = (double)mode;
    if (c->nvar > 0) {
        c->arg[0] = Y; c->arg[1] = Y + c->n; c->arg[2] = &md; c->arg[3] = c->P;
        c->res[0] = dY; c->res[1] = dY + c->n;
        ocp_varflow(c->arg, c->res, c->iw, c->w, 0);
    } else {
        c->arg[0] = Y; c->arg[1] = &md; c->arg[2] = c->P;
        c->res[0] = dY;
        ocp_flow(c->arg, c->res, c->iw, c->w, 0);
    }
    c->nfev++;
    return mode;
}

static double ham(Ctx *c, const double *y, int mode) {
    double md = (double)mode, h = 0.0;
    c->arg[0] = y; c->arg[1] = &md; c->arg[2] = c->P;
    c->res[0] = &h;
    ocp_ham(c->arg, c->res, c->iw, c->w, 0);
    return h;
}

/* one Dormand-Prince step of size h from (y, k1) in a fixed mode (or mode -1: re-evaluated);
   fills y1 (5th order), k2..k7 (k7 = f(y1)) and returns the scaled error norm on the base state */
static double dp_step(Ctx *c, const double *y, const double *k1, double h, int mode, int *sc) {
    int N = c->N, n = c->n;
    double *yt = c->ysti;
    for (int i = 0; i < N; i++) yt[i] = y[i] + h * a21 * k1[i];
    rhs(c, yt, mode, c->k2, sc);
    for (int i = 0; i < N; i++) yt[i] = y[i] + h * (a31 * k1[i] + a32 * c->k2[i]);
    rhs(c, yt, mode, c->k3, sc);
    for (int i = 0; i < N; i++) yt[i] = y[i] + h * (a41 * k1[i] + a42 * c->k2[i] + a43 * c->k3[i]);
    rhs(c, yt, mode, c->k4, sc);
    for (int i = 0; i < N; i++)
        yt[i] = y[i] + h * (a51 * k1[i] + a52 * c->k2[i] + a53 * c->k3[i] + a54 * c->k4[i]);
    rhs(c, yt, mode, c->k5, sc);
    for (int i = 0; i < N; i++)
        yt[i] = y[i] + h * (a61 * k1[i] + a62 * c->k2[i] + a63 * c->k3[i] + a64 * c->k4[i] + a65 * c->k5[i]);
    rhs(c, yt, mode, c->k6, sc);
    for (int i = 0; i < N; i++)
        c->y1[i] = y[i] + h * (a71 * k1[i] + a73 * c->k3[i] + a74 * c->k4[i] + a75 * c->k5[i] + a76 * c->k6[i]);
    rhs(c, c->y1, mode, c->k7, sc);
    double err = 0.0;
    for (int i = 0; i < n; i++) {
        double e = h * (e1 * k1[i] + e3 * c->k3[i] + e4 * c->k4[i] + e5 * c->k5[i] + e6 * c->k6[i] + e7 * c->k7[i]);
        double sk = c->atol + c->rtol * fmax(fabs(y[i]), fabs(c->y1[i]));
        err += (e / sk) * (e / sk);
    }
    return sqrt(err / n);
}

/* dense output coefficients of the last step (all N components) */
static void dense_prepare(Ctx *c, const double *y, const double *k1, double h) {
    int N = c->N;
    double *r = c->cont;
    for (int i = 0; i < N; i++) {
        double ydiff = c->y1[i] - y[i];
        double bspl = h * k1[i] - ydiff;
        r[i] = y[i];
        r[N + i] = ydiff;
        r[2 * N + i] = bspl;
        r[3 * N + i] = ydiff - h * c->k7[i] - bspl;
        r[4 * N + i] = h * (d1 * k1[i] + d3 * c->k3[i] + d4 * c->k4[i] + d5 * c->k5[i] + d6 * c->k6[i] + d7 * c->k7[i]);
    }
}

static void dense_eval(const Ctx *c, double theta, int count, double *out) {
    int N = c->N;
    const double *r = c->cont;
    double t1 = 1.0 - theta;
    for (int i = 0; i < count; i++)
        out[i] = r[i] + theta * (r[N + i] + t1 * (r[2 * N + i] + theta * (r[3 * N + i] + t1 * r[4 * N + i])));
}

/* zero of g_k along the dense output on theta in (a, b] (g_k(a) = ga, g_k(b) = gb of opposite
   signs), Illinois variant of regula falsi. An iterate within 1e-9 of the bracket's width from
   an end is replaced by the midpoint: right after a switching g_k(a) is rounding noise, and the
   secant would otherwise probe g where its sign is noise too. */
static double dense_root(Ctx *c, int k, double a, double b, double ga, double gb) {
    double fa = ga, fb = gb;
    int side = 0;
    for (int it = 0; it < 200; it++) {
        double m = b - fb * (b - a) / (fb - fa);
        double guard = 1e-9 * (b - a);
        if (!(m > a + guard && m < b - guard)) m = 0.5 * (a + b);
        dense_eval(c, m, c->n, c->ytmp);
        switching(c, c->ytmp, c->gtmp);
        double fm = c->gtmp[k];
        if (fm == 0.0 || (b - a) < 1e-15) return m;
        if ((fm > 0) == (fb > 0)) {
            b = m; fb = fm;
            if (side == -1) fa *= 0.5;
            side = -1;
        } else {
            a = m; fa = fm;
            if (side == 1) fb *= 0.5;
            side = 1;
        }
        if (fabs(b - a) < 4e-16 * fmax(1.0, fabs(b))) break;
    }
    return fabs(fa) < fabs(fb) ? a : b;
}

/* dg_k/dt = dg_k/dy . f at y (f: the first n entries of dy) for every k */
static void switching_rates(Ctx *c, const double *y, const double *dy, double *rate) {
    c->arg[0] = y; c->arg[1] = c->P; c->res[0] = c->dg;
    ocp_dswitch(c->arg, c->res, c->iw, c->w, 0);
    for (int k = 0; k < c->ng; k++) {
        double r = 0;
        for (int i = 0; i < c->n; i++) r += c->dg[k + (size_t)i * c->ng] * dy[i];
        rate[k] = r;
    }
}

/* theta in (0, 1) where the cubic Hermite interpolant of g on a step (values g0, g1, slopes
   s0 = h dg/dt(t), s1 = h dg/dt(t + h)) has an interior extremum that comes within half of
   min(|g0|, |g1|) of zero from the mode's side (side = 1: g > 0), or crosses it; the earliest
   such, -1 if none. A heuristic: it tells where to look on the dense output, not whether g crosses. */
static double interior_suspect(int side, double g0, double g1, double s0, double s1) {
    double sg = side ? 1.0 : -1.0;
    double b = s0, cc = -3 * g0 - 2 * s0 + 3 * g1 - s1, d = 2 * g0 + s0 - 2 * g1 + s1;
    double roots[2];
    int nr = 0;
    if (fabs(d) < 1e-14 * (fabs(b) + fabs(cc))) {
        if (cc != 0) roots[nr++] = -b / (2 * cc);
    } else {
        double disc = cc * cc - 3 * d * b;
        if (disc < 0) return -1.0;
        double q = -(cc + (cc >= 0 ? 1 : -1) * sqrt(disc));
        roots[nr++] = q / (3 * d);
        if (q != 0) roots[nr++] = b / q;
    }
    if (nr == 2 && roots[1] < roots[0]) { double tmp = roots[0]; roots[0] = roots[1]; roots[1] = tmp; }
    double margin = 0.5 * fmin(fabs(g0), fabs(g1));
    for (int r = 0; r < nr; r++) {
        double th = roots[r];
        if (!(th > 0.0 && th < 1.0)) continue;
        double p = g0 + th * (b + th * (cc + th * d));
        if (sg * p < margin) return th;
    }
    return -1.0;
}

int ocp_integrate(const double *y0, double t0, double tf, const double *P, const int *opt_int,
                  const double *opt_dbl, const int *group_sizes, double *y_out, long long *out,
                  double *hist_t, double *hist_h, double *hist_H, double *rej_t, double *rej_h,
                  double *sw_t, int *sw_k, double *hist_y) {
    Ctx C;
    Ctx *c = &C;
    memset(c, 0, sizeof(Ctx));
    c->n = opt_int[I_N];
    c->nvar = opt_int[I_NVAR];
    c->N = c->n * (1 + c->nvar);
    c->ng = opt_int[I_NG];
    c->ngroups = opt_int[I_NGROUPS];
    c->detect = opt_int[I_DETECT];
    c->group_sizes = group_sizes;
    c->P = P;
    c->rtol = opt_dbl[D_RTOL];
    c->atol = opt_dbl[D_ATOL];
    long maxsteps = opt_int[I_MAXSTEPS];
    int record = opt_int[I_RECORD];
    long cap = opt_int[I_CAP];
    int interior = c->detect > 0 && opt_int[I_INTERIOR];
    double hmax = opt_dbl[D_HMAX] > 0 ? opt_dbl[D_HMAX] : fabs(tf - t0);
    int n = c->n, N = c->N, ng = c->ng, nvar = c->nvar;
    for (int i = 0; i < O_NOUT; i++) out[i] = 0;

    casadi_int m[4] = {0, 0, 0, 0};
    work_max(ocp_flow_work, m);
    work_max(ocp_varflow_work, m);
    work_max(ocp_switching_work, m);
    work_max(ocp_dswitch_work, m);
    work_max(ocp_ham_work, m);
    c->arg = malloc(sizeof(casadi_real *) * (m[0] + 1));
    c->res = malloc(sizeof(casadi_real *) * (m[1] + 1));
    c->iw = malloc(sizeof(casadi_int) * (m[2] + 1));
    c->w = malloc(sizeof(casadi_real) * (m[3] + 1));
    double *buf = malloc(sizeof(double) * (17 * (size_t)N + 7 * (size_t)ng + (size_t)ng * n + 3 * (size_t)n));
    int *signs = malloc(sizeof(int) * (3 * (size_t)ng + 1));
    if (!c->arg || !c->res || !c->iw || !c->w || !buf || !signs) {
        out[O_STATUS] = NO_MEMORY;
        return NO_MEMORY;
    }
    double *p = buf;
    double *y = p; p += N;
    c->k1 = p; p += N; c->k2 = p; p += N; c->k3 = p; p += N; c->k4 = p; p += N;
    c->k5 = p; p += N; c->k6 = p; p += N; c->k7 = p; p += N;
    c->y1 = p; p += N; c->ysti = p; p += N; c->cont = p; p += 5 * N;
    double *ysave = p; p += N;
    c->g = p; p += ng; c->gtmp = p; p += ng;
    double *gnew = p; p += ng; double *theta_k = p; p += ng;
    double *rate0 = p; p += ng; double *rate1 = p; p += ng; /* dg/dt at the step's start and end */
    double *hi_k = p; p += ng; /* the crossing of g_k lies in theta in (0, hi_k] */
    c->dg = p; p += (size_t)ng * n;
    c->phiI = p; p += n; c->phiII = p; p += n; c->ytmp = p; p += n;
    int *sc = signs + ng; /* scratch signs for mode -1 evaluations */
    int *inside = signs + 2 * ng; /* the crossing found for g_k opens an arc inside the step */

    memcpy(y, y0, sizeof(double) * N);
    double t = t0;
    int status = OK;
    long accepted = 0, rejected = 0, nswitch = 0, nhist = 0, nrej = 0, nsw = 0, ninterior = 0;

    switching(c, y, c->g);
    signs_of(c, c->g, signs);
    int mode = mode_from_signs(c, signs);
    int step_mode = c->detect == 0 ? -1 : mode;
    rhs(c, y, step_mode, c->k1, sc);
    if (interior) switching_rates(c, y, c->k1, rate0);

    /* initial step size (Hairer's hinit) */
    double h = opt_dbl[D_H0];
    if (!(h > 0)) {
        double dnf = 0, dny = 0;
        for (int i = 0; i < n; i++) {
            double sk = c->atol + c->rtol * fabs(y[i]);
            dnf += (c->k1[i] / sk) * (c->k1[i] / sk);
            dny += (y[i] / sk) * (y[i] / sk);
        }
        h = (dnf <= 1e-10 || dny <= 1e-10) ? 1e-6 : 0.01 * sqrt(dny / dnf);
        h = fmin(h, hmax);
        for (int i = 0; i < N; i++) c->ysti[i] = y[i] + h * c->k1[i];
        rhs(c, c->ysti, step_mode, c->k2, sc);
        double der2 = 0;
        for (int i = 0; i < n; i++) {
            double sk = c->atol + c->rtol * fabs(y[i]);
            double d = (c->k2[i] - c->k1[i]) / sk;
            der2 += d * d;
        }
        der2 = sqrt(der2) / h;
        double der12 = fmax(fabs(der2), sqrt(dnf));
        double h1 = der12 <= 1e-15 ? fmax(1e-6, fabs(h) * 1e-3) : pow(0.01 / der12, 0.2);
        h = fmin(fmin(100 * fabs(h), h1), hmax);
    }

    const double safe = 0.9, facc1 = 1.0 / 0.2, facc2 = 1.0 / 10.0, beta = 0.04;
    const double expo1 = 0.2 - beta * 0.75;
    double facold = 1e-4;
    int reject = 0, last = 0;

    if (record && nhist < cap) {
        hist_t[nhist] = t; hist_h[nhist] = 0.0; hist_H[nhist] = ham(c, y, c->detect == 0 ? mode_from_signs(c, signs) : mode);
        if (hist_y) memcpy(hist_y + (size_t)nhist * n, y, sizeof(double) * n);
        nhist++;
    }

    while (1) {
        if (accepted + rejected >= maxsteps) { status = MAX_STEPS; break; }
        if (0.1 * fabs(h) <= fabs(t) * 1e-15) { status = STEP_TOO_SMALL; break; }
        if ((t + 1.01 * h - tf) >= 0.0) { h = tf - t; last = 1; }
        double err = dp_step(c, y, c->k1, h, step_mode, sc);
        if (!isfinite(err)) {
            if (h < 1e-300) { status = NOT_FINITE; break; }
            h *= 0.1; reject = 1; last = 0; rejected++;
            continue;
        }
        double fac11 = pow(err, expo1);
        double fac = fac11 / pow(facold, beta);
        fac = fmax(facc2, fmin(facc1, fac / safe));
        double hnew = h / fac;
        if (err > 1.0) {
            hnew = h / fmin(facc1, fac11 / safe);
            if (record && nrej < cap) { rej_t[nrej] = t; rej_h[nrej] = h; nrej++; }
            rejected++;
            reject = 1; last = 0;
            h = hnew;
            continue;
        }
        /* step accepted (possibly truncated at a switching) */
        facold = fmax(err, 1e-4);
        int switched = 0;
        if (c->detect > 0) {
            switching(c, c->y1, gnew);
            if (interior) switching_rates(c, c->y1, c->k7, rate1);
            int first = -1, prepared = 0;
            double theta = 2.0;
            for (int k = 0; k < ng; k++) {
                theta_k[k] = 2.0;
                hi_k[k] = 1.0;
                inside[k] = 0;
                int crossed = (gnew[k] > 0) != signs[k];
                /* just after a switching g_k is zero to rounding, possibly on the side it left: it starts
                   on the side its mode says (the zero at the step's start is the switching itself) */
                double g0 = c->g[k];
                if (g0 == 0.0 || (g0 > 0) != signs[k]) g0 = signs[k] ? DBL_MIN : -DBL_MIN;
                if (interior) {
                    /* an excursion through zero before the step's end: the first crossing lies before it
                       (a short arc when the ends agree, the first of three crossings when they do not) */
                    double th = interior_suspect(signs[k], g0, gnew[k], h * rate0[k], h * rate1[k]);
                    if (th > 0) {
                        if (!prepared) { dense_prepare(c, y, c->k1, h); prepared = 1; }
                        dense_eval(c, th, n, c->ytmp);
                        switching(c, c->ytmp, c->gtmp);
                        double gm = c->gtmp[k];
                        if ((gm > 0) != signs[k]) {
                            theta_k[k] = dense_root(c, k, 0.0, th, g0, gm);
                            hi_k[k] = th;
                            inside[k] = !crossed; /* an arc the end-of-step test would miss */
                        }
                    }
                }
                if (crossed && theta_k[k] > 1.0) {
                    if (!prepared) { dense_prepare(c, y, c->k1, h); prepared = 1; }
                    theta_k[k] = dense_root(c, k, 0.0, 1.0, g0, gnew[k]);
                }
                if (theta_k[k] <= 1.0) {
                    first = k;
                    if (theta_k[k] < theta) theta = theta_k[k];
                }
            }
            if (first >= 0) {
                int kstar = 0;
                for (int k = 0; k < ng; k++) if (theta_k[k] == theta) { kstar = k; break; }
                double tau = t + theta * h, t_hi = t + hi_k[kstar] * h;
                if (inside[kstar]) ninterior++;
                if (c->detect == 1) {
                    dense_eval(c, theta, N, ysave);
                } else {
                    /* correction: zero of g_k(y1(tau)) with y1 an actual DP step of size tau - t */
                    double ta = t + theta * h, fa, tb, fb;
                    memcpy(ysave, y, sizeof(double) * N);
                    dp_step(c, ysave, c->k1, ta - t, mode, sc);
                    switching(c, c->y1, c->gtmp);
                    fa = c->gtmp[kstar];
                    /* Newton step with dg/dy . phi for the second point */
                    c->arg[0] = c->y1; c->arg[1] = c->P; c->res[0] = c->dg;
                    ocp_dswitch(c->arg, c->res, c->iw, c->w, 0);
                    flow(c, c->y1, mode, c->phiI);
                    double slope = 0;
                    for (int i = 0; i < n; i++) slope += c->dg[kstar + (size_t)i * ng] * c->phiI[i];
                    tb = (slope != 0.0) ? ta - fa / slope : ta;
                    if (!(tb > t && tb <= t_hi)) tb = ta;
                    fb = fa;
                    for (int it = 0; it < 30 && tb != ta; it++) {
                        dp_step(c, ysave, c->k1, tb - t, mode, sc);
                        switching(c, c->y1, c->gtmp);
                        fb = c->gtmp[kstar];
                        if (fb == 0.0 || fabs(tb - ta) <= 4e-16 * fmax(fabs(tb), 1.0)) break;
                        double tn = (fb != fa) ? tb - fb * (tb - ta) / (fb - fa) : tb;
                        if (!(tn > t && tn <= t_hi)) tn = 0.5 * (ta + tb);
                        ta = tb; fa = fb; tb = tn;
                    }
                    if (tb != ta || fb != fa) {
                        dp_step(c, ysave, c->k1, tb - t, mode, sc);
                    }
                    tau = tb;
                    memcpy(ysave, c->y1, sizeof(double) * N);
                }
                /* ysave holds y(tau-); switch the crossed component(s) (simultaneous crossings together) */
                int newsigns_changed = 0;
                for (int k = 0; k < ng; k++) {
                    if (theta_k[k] <= theta + 1e-12) { signs[k] = !signs[k]; newsigns_changed++; }
                }
                int newmode = mode_from_signs(c, signs);
                if (nvar > 0) {
                    flow(c, ysave, mode, c->phiI);
                    flow(c, ysave, newmode, c->phiII);
                    c->arg[0] = ysave; c->arg[1] = c->P; c->res[0] = c->dg;
                    ocp_dswitch(c->arg, c->res, c->iw, c->w, 0);
                    double den = 0;
                    for (int i = 0; i < n; i++) den += c->dg[kstar + (size_t)i * ng] * c->phiI[i];
                    double *Psi = ysave + n;
                    for (int j = 0; j < nvar; j++) {
                        double num = 0;
                        for (int i = 0; i < n; i++) num += c->dg[kstar + (size_t)i * ng] * Psi[i + (size_t)j * n];
                        double dtau = den != 0.0 ? -num / den : 0.0;
                        for (int i = 0; i < n; i++) Psi[i + (size_t)j * n] += (c->phiI[i] - c->phiII[i]) * dtau;
                    }
                }
                if (record && nhist < cap) {
                    hist_t[nhist] = tau; hist_h[nhist] = tau - t; hist_H[nhist] = ham(c, ysave, newmode);
                    if (hist_y) memcpy(hist_y + (size_t)nhist * n, ysave, sizeof(double) * n);
                    nhist++;
                }
                if (record && nsw < cap) { sw_t[nsw] = tau; sw_k[nsw] = kstar; nsw++; }
                nswitch += newsigns_changed;
                accepted++;
                memcpy(y, ysave, sizeof(double) * N);
                t = tau;
                mode = newmode;
                step_mode = mode;
                switching(c, y, c->g);
                rhs(c, y, step_mode, c->k1, sc);
                if (interior) switching_rates(c, y, c->k1, rate0);
                switched = 1;
                last = 0;
                reject = 0;
                /* a switching at tf (to rounding): nothing is left to integrate, and a sub-ulp step
                   would see the crossed function still on its old side */
                if (t >= tf || tf - t <= 8.0 * 2.220446049250313e-16 * fmax(1.0, fabs(tf))) break;
                continue;
            }
            memcpy(c->g, gnew, sizeof(double) * ng);
        }
        if (!switched) {
            accepted++;
            if (c->detect == 0) {
                /* count sign changes for the report */
                switching(c, c->y1, gnew);
                int s2;
                for (int k = 0; k < ng; k++) {
                    s2 = gnew[k] > 0;
                    if (s2 != signs[k]) { nswitch++; signs[k] = s2; if (record && nsw < cap) { sw_t[nsw] = t + h; sw_k[nsw] = k; nsw++; } }
                }
            }
            memcpy(c->k1, c->k7, sizeof(double) * N);
            memcpy(y, c->y1, sizeof(double) * N);
            if (interior) memcpy(rate0, rate1, sizeof(double) * ng);
            double hstep = h;
            t += h;
            if (record && nhist < cap) {
                hist_t[nhist] = t; hist_h[nhist] = hstep;
                hist_H[nhist] = ham(c, y, c->detect == 0 ? mode_from_signs(c, signs) : mode);
                if (hist_y) memcpy(hist_y + (size_t)nhist * n, y, sizeof(double) * n);
                nhist++;
            }
            if (last) break;
            if (fabs(hnew) > hmax) hnew = hmax;
            if (reject) hnew = fmin(fabs(hnew), fabs(h));
            reject = 0;
            h = hnew;
        }
    }
    memcpy(y_out, y, sizeof(double) * N);
    out[O_STATUS] = status;
    out[O_ACCEPTED] = accepted;
    out[O_REJECTED] = rejected;
    out[O_NFEV] = c->nfev;
    out[O_SWITCHES] = nswitch;
    out[O_NHIST] = nhist;
    out[O_NREJ] = nrej;
    out[O_NSW] = nsw;
    out[O_INTERIOR] = ninterior;
    free(c->arg); free(c->res); free(c->iw); free(c->w); free(buf); free(signs);
    return status;
}
