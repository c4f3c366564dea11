/* Radau IIA of order 5 (Hairer's RADAU5 scheme): it takes the rates and the first step of rk4.c
   and dop853.c, the Jacobians and the LU of jacobian.c. */

#include "solver_internal.h"

/* ---- Radau IIA, order 5: Hairer and Wanner, Solving ODEs II, sec. IV.8 (RADAU5) ------------- */

/* The 3-stage collocation method at the nodes RADAU_C1, RADAU_C2 and 1. Its matrix A^-1 is
   T diag(GAMMA, [[ALPHA, -BETA], [BETA, ALPHA]]) T^-1 (T and TI = T^-1 as in Hairer's code), so
   simplified Newton on the 3 stages splits into one real system (GAMMA / h I - J) and one complex
   ((ALPHA + i BETA) / h I - J). RADAU_E: the embedded estimate's weights of the stage increments
   z (times 1 / h), (-(13 + 7 sqrt 6) / 3, (-13 + 7 sqrt 6) / 3, -1 / 3). */
static const double RADAU_C1 = 0.15505102572168222, RADAU_C2 = 0.6449489742783178;
static const double RADAU_GAMMA = 3.6378342527444962, RADAU_ALPHA = 2.6810828736277523,
                    RADAU_BETA = 3.0504301992474105;
static const double RADAU_E[3] = { -10.048809399827414, 1.382142733160748, -1.0 / 3.0 };
static const double RADAU_T[3][3] = {
    { 9.1232394870892942792e-02, -0.14125529502095420843, -3.0029194105147424492e-02 },
    { 0.24171793270710701896, 0.20412935229379993199, 0.38294211275726193779 },
    { 0.96604818261509293619, 1.0, 0.0 },
};
static const double RADAU_TI[3][3] = {
    { 4.3255798900631553510, 0.33919925181580986954, 0.54177053993587487119 },
    { -4.1787185915519047273, -0.32768282076106238708, 0.47662355450055045196 },
    { -0.50287263494578687595, 2.5719269498556054292, -0.59603920482822492497 },
};

/* Hairer's defaults: at most RADAU_ITERATIONS Newton iterations a step; the step (and so its LUs)
   kept when the new one would be 1 to RADAU_KEEP_STEP times it; a step grows at most
   RADAU_GROWTH-fold and shrinks to RADAU_SHRINK of it at the least, after RADAU_SAFETY. The
   Jacobian is kept while Newton contracts by RADAU_KEEP_JACOBIAN or faster: Hairer's value for
   costly Jacobians (his default 1e-3 is for cheap ones), as the GPME's are (the 4 n + 1 solves of
   central differences, or a (n + m) LU): at n_rfe 5 it cut them from 1390 to 859 over 1 s at
   rtol 1e-4 and the wall time by a third, steps and errors the same. */
enum { RADAU_ITERATIONS = 7 };
static const double RADAU_SAFETY = 0.9, RADAU_KEEP_JACOBIAN = 0.1, RADAU_KEEP_STEP = 1.2;
static const double RADAU_GROWTH = 8.0, RADAU_SHRINK = 0.2;

/* The Newton matrices of a step h (see radau_solve): with the Jacobian
   J = [[0, I, 0], [A_q, A_qd, A_z], [R_q, R_qd, R_z]] of [qd, qdd, dz/dt] in [q, qd, z] (z the
   controller states, N_Z of them, and r their rates; the rates of w do not feed back: their rows
   of J are taken as zero, exact for the stages once the rest has converged), (s I - J) x = r
   reduces, with x_qd = s x_q - r_q and x_w = r_w / s, to the N_R = N_DOF + N_Z system
       [[s^2 I - s A_qd - A_q, -A_z], [-R_q - s R_qd, s I - R_z]] [x_q, x_z]
           = [r_qd + (s I - A_qd) r_q, r_z - R_qd r_q].
   real: that matrix at s = GAMMA / h, LU-factored; re, im: at s = (ALPHA + i BETA) / h, the real
   and imaginary parts of its complex LU; A_qd and R_qd kept for the right-hand sides. */
struct radau_matrices {
    int n_dof, n_z;
    double *A_qd, *real, *re, *im;  /* N_DOF x N_DOF; N_R x N_R each */
    const double *A_z, *R_q, *R_qd, *R_z;  /* N_DOF x N_Z, N_Z x N_DOF (two), N_Z x N_Z */
    int *real_pivot, *complex_pivot;  /* N_R each */
    double s_real, s_re, s_im;
};

/* LU factorization with partial pivoting of the complex n x n matrix re + i im (row-major), in
   place as gpmegen_lu_factor's. Returns GPMEGEN_NONFINITE or GPMEGEN_SINGULAR as it does. */
static int complex_lu_factor(int n, double *re, double *im, int *piv)
{
    double largest = 0.0;
    for (int i = 0; i < n * n; ++i) {
        if (!isfinite(re[i]) || !isfinite(im[i])) {
            return GPMEGEN_NONFINITE;
        }
        largest = fmax(largest, hypot(re[i], im[i]));
    }
    const double tiny = (double)n * DBL_EPSILON * largest;
    for (int k = 0; k < n; ++k) {
        int r = k;
        for (int i = k + 1; i < n; ++i) {
            r = hypot(re[i * n + k], im[i * n + k]) > hypot(re[r * n + k], im[r * n + k]) ? i : r;
        }
        if (!(hypot(re[r * n + k], im[r * n + k]) > tiny)) {
            return GPMEGEN_SINGULAR;
        }
        piv[k] = r;
        if (r != k) {
            for (int j = 0; j < n; ++j) {
                double s = re[k * n + j];
                re[k * n + j] = re[r * n + j];
                re[r * n + j] = s;
                s = im[k * n + j];
                im[k * n + j] = im[r * n + j];
                im[r * n + j] = s;
            }
        }
        const double size = re[k * n + k] * re[k * n + k] + im[k * n + k] * im[k * n + k];
        const double inv_re = re[k * n + k] / size, inv_im = -im[k * n + k] / size;
        for (int i = k + 1; i < n; ++i) {
            const double l_re = re[i * n + k] * inv_re - im[i * n + k] * inv_im;
            const double l_im = re[i * n + k] * inv_im + im[i * n + k] * inv_re;
            re[i * n + k] = l_re;
            im[i * n + k] = l_im;
            for (int j = k + 1; j < n; ++j) {
                re[i * n + j] -= l_re * re[k * n + j] - l_im * im[k * n + j];
                im[i * n + j] -= l_re * im[k * n + j] + l_im * re[k * n + j];
            }
        }
    }
    return GPMEGEN_OK;
}

/* Solves (re + i im) x = b_re + i b_im (n,), overwritten by x, with complex_lu_factor's LU. */
static void complex_lu_solve(int n, const double *re, const double *im, const int *piv, double *b_re,
                                      double *b_im)
{
    for (int i = 0; i < n; ++i) {
        if (piv[i] != i) {
            double s = b_re[i];
            b_re[i] = b_re[piv[i]];
            b_re[piv[i]] = s;
            s = b_im[i];
            b_im[i] = b_im[piv[i]];
            b_im[piv[i]] = s;
        }
    }
    for (int i = 1; i < n; ++i) {
        for (int r = 0; r < i; ++r) {
            b_re[i] -= re[i * n + r] * b_re[r] - im[i * n + r] * b_im[r];
            b_im[i] -= re[i * n + r] * b_im[r] + im[i * n + r] * b_re[r];
        }
    }
    for (int i = n - 1; i >= 0; --i) {
        for (int r = i + 1; r < n; ++r) {
            b_re[i] -= re[i * n + r] * b_re[r] - im[i * n + r] * b_im[r];
            b_im[i] -= re[i * n + r] * b_im[r] + im[i * n + r] * b_re[r];
        }
        const double size = re[i * n + i] * re[i * n + i] + im[i * n + i] * im[i * n + i];
        const double x_re = (b_re[i] * re[i * n + i] + b_im[i] * im[i * n + i]) / size;
        b_im[i] = (b_im[i] * re[i * n + i] - b_re[i] * im[i * n + i]) / size;
        b_re[i] = x_re;
    }
}

/* The Newton matrices of step h from the Jacobian dqdd/dq (A_q) and m->A_qd, factored into m.
   Returns GPMEGEN_OK, or GPMEGEN_SINGULAR / GPMEGEN_NONFINITE of a factorization. */
static int radau_factor(double h, const double *A_q, struct radau_matrices *m)
{
    const int N_DOF = m->n_dof, N_Z = m->n_z, N_R = N_DOF + N_Z;
    const double g = RADAU_GAMMA / h, a = RADAU_ALPHA / h, b = RADAU_BETA / h;
    int status;
    m->s_real = g;
    m->s_re = a;
    m->s_im = b;
    for (int i = 0; i < N_DOF; ++i) {  /* s^2 I - s A_qd - A_q, s^2 = a^2 - b^2 + 2 a b i; -A_z */
        for (int j = 0; j < N_DOF; ++j) {
            const double A_qd = m->A_qd[i * N_DOF + j], A = A_q[i * N_DOF + j];
            m->real[i * N_R + j] = -g * A_qd - A;
            m->re[i * N_R + j] = -a * A_qd - A;
            m->im[i * N_R + j] = -b * A_qd;
        }
        for (int j = 0; j < N_Z; ++j) {
            m->real[i * N_R + N_DOF + j] = m->re[i * N_R + N_DOF + j] = -m->A_z[i * N_Z + j];
            m->im[i * N_R + N_DOF + j] = 0.0;
        }
        m->real[i * N_R + i] += g * g;
        m->re[i * N_R + i] += a * a - b * b;
        m->im[i * N_R + i] += 2.0 * a * b;
    }
    for (int k = 0; k < N_Z; ++k) {  /* -R_q - s R_qd; s I - R_z */
        double *real = m->real + (N_DOF + k) * N_R, *re = m->re + (N_DOF + k) * N_R, *im = m->im + (N_DOF + k) * N_R;
        for (int j = 0; j < N_DOF; ++j) {
            const double R_qd = m->R_qd[k * N_DOF + j], R = m->R_q[k * N_DOF + j];
            real[j] = -R - g * R_qd;
            re[j] = -R - a * R_qd;
            im[j] = -b * R_qd;
        }
        for (int j = 0; j < N_Z; ++j) {
            real[N_DOF + j] = re[N_DOF + j] = -m->R_z[k * N_Z + j];
            im[N_DOF + j] = 0.0;
        }
        real[N_DOF + k] += g;
        re[N_DOF + k] += a;
        im[N_DOF + k] += b;
    }
    if ((status = gpmegen_lu_factor(N_R, m->real, m->real_pivot)) != GPMEGEN_OK) {
        return status;
    }
    return complex_lu_factor(N_R, m->re, m->im, m->complex_pivot);
}

/* A_qd times the q part of r (N_DOF), then R_qd times it (N_Z): the products with r_q of the
   reduced right-hand sides (out: N_R). */
static void times_A_qd(const struct radau_matrices *m, const double *r, double *out)
{
    const int N_DOF = m->n_dof, N_Z = m->n_z;
    for (int i = 0; i < N_DOF; ++i) {
        double s = 0.0;
        for (int j = 0; j < N_DOF; ++j) {
            s += m->A_qd[i * N_DOF + j] * r[j];
        }
        out[i] = s;
    }
    for (int k = 0; k < N_Z; ++k) {
        double s = 0.0;
        for (int j = 0; j < N_DOF; ++j) {
            s += m->R_qd[k * N_DOF + j] * r[j];
        }
        out[N_DOF + k] = s;
    }
}

/* Solves (s_real I - J) x = r (N_Y, overwritten by x) by the reduction of struct radau_matrices. */
static void radau_solve_real(const struct radau_matrices *m, double *r)
{
    const int N_DOF = m->n_dof, N_Z = m->n_z, N_R = N_DOF + N_Z, N_MOTION = 2 * N_DOF;
    const double s = m->s_real;
    double x[N_R] ALIGNED, *r_z = r + N_MOTION + 2;
    times_A_qd(m, r, x);
    for (int i = 0; i < N_DOF; ++i) {
        x[i] = r[N_DOF + i] + s * r[i] - x[i];
    }
    for (int k = 0; k < N_Z; ++k) {
        x[N_DOF + k] = r_z[k] - x[N_DOF + k];
    }
    gpmegen_lu_solve(N_R, m->real, m->real_pivot, 1, x);
    for (int i = 0; i < N_DOF; ++i) {
        r[N_DOF + i] = s * x[i] - r[i];
        r[i] = x[i];
    }
    for (int k = 0; k < N_Z; ++k) {
        r_z[k] = x[N_DOF + k];
    }
    r[N_MOTION] /= s;
    r[N_MOTION + 1] /= s;
}

/* Solves ((s_re + i s_im) I - J) (x + i y) = r + i u (N_Y each, overwritten by x and y). */
static void radau_solve_complex(const struct radau_matrices *m, double *r, double *u)
{
    const int N_DOF = m->n_dof, N_Z = m->n_z, N_R = N_DOF + N_Z, N_MOTION = 2 * N_DOF;
    const double a = m->s_re, b = m->s_im;
    double x[N_R] ALIGNED, y[N_R] ALIGNED, *r_z = r + N_MOTION + 2, *u_z = u + N_MOTION + 2;
    times_A_qd(m, r, x);
    times_A_qd(m, u, y);
    for (int i = 0; i < N_DOF; ++i) {
        x[i] = r[N_DOF + i] + a * r[i] - b * u[i] - x[i];
        y[i] = u[N_DOF + i] + a * u[i] + b * r[i] - y[i];
    }
    for (int k = 0; k < N_Z; ++k) {
        x[N_DOF + k] = r_z[k] - x[N_DOF + k];
        y[N_DOF + k] = u_z[k] - y[N_DOF + k];
    }
    complex_lu_solve(N_R, m->re, m->im, m->complex_pivot, x, y);
    for (int i = 0; i < N_DOF; ++i) {
        r[N_DOF + i] = a * x[i] - b * y[i] - r[i];
        u[N_DOF + i] = a * y[i] + b * x[i] - u[i];
        r[i] = x[i];
        u[i] = y[i];
    }
    for (int k = 0; k < N_Z; ++k) {
        r_z[k] = x[N_DOF + k];
        u_z[k] = y[N_DOF + k];
    }
    const double size = a * a + b * b;
    for (int i = N_MOTION; i < N_MOTION + 2; ++i) {
        const double re = (r[i] * a + u[i] * b) / size;
        u[i] = (u[i] * a - r[i] * b) / size;
        r[i] = re;
    }
}

/* The dense output of a step from (t, y0) of length h: y(t + x h) = y0 + h sum_j W_j(x) F_j,
   0 <= x <= 1, with F_0 = f(t, y0) and F_1..3 the stages' rates (Lambda / h w back-transformed,
   what the collocation conditions make them), W_j(x) = the integral from 0 to x of the Lagrange
   polynomial of the nodes 0, c1, c2, 1 that is 1 at node j: RADAU_W[j] its coefficients of x^1..x^4.
   Exact for polynomials of degree 4 and so, in y, one order above the collocation polynomial
   (degree 3, the stages alone), whose error between the steps was 30-200 times rtol at rtol
   1e-8..1e-10 on the reference arm. At x = 1 it is the step's y (the quadrature is the method's). */
static const double RADAU_W[4][4] = {
    { 1.0, -4.5, 6.0, -2.5 },
    { 0.0, 5.0244046999137077812, -8.5431971490255464623, 3.8951955118123059561 },
    { 0.0, -0.69107136658037444790, 3.4320860379144353511, -2.2285288451456392894 },
    { 0.0, 1.0 / 6.0, -8.0 / 9.0, 5.0 / 6.0 },
};

/* The stages' rates F (3 x N_Y) times h from the transformed increments w: T Lambda w. */
static void radau_stage_rates(int N_Y, const double w[][N_Y], double F[][N_Y])
{
    for (int i = 0; i < N_Y; ++i) {
        const double v0 = RADAU_GAMMA * w[0][i], v1 = RADAU_ALPHA * w[1][i] - RADAU_BETA * w[2][i];
        const double v2 = RADAU_BETA * w[1][i] + RADAU_ALPHA * w[2][i];
        for (int k = 0; k < 3; ++k) {
            F[k][i] = RADAU_T[k][0] * v0 + RADAU_T[k][1] * v1 + RADAU_T[k][2] * v2;
        }
    }
}

/* y at t + x h by the dense output above from y0, h f0 = h f(t, y0) and hF (3 x N_Y, of
   radau_stage_rates) into out (N_Y). */
static void radau_dense_value(int N_Y, double x, double h, const double *y0, const double *f0, const double hF[][N_Y],
                              double *out)
{
    double weight[4] ALIGNED;
    for (int j = 0; j < 4; ++j) {
        weight[j] = x * (RADAU_W[j][0] + x * (RADAU_W[j][1] + x * (RADAU_W[j][2] + x * RADAU_W[j][3])));
    }
    for (int i = 0; i < N_Y; ++i) {
        out[i] = y0[i] + weight[0] * h * f0[i] + weight[1] * hF[0][i] + weight[2] * hF[1][i] + weight[3] * hF[2][i];
    }
}

/* The place in y = [q, qd, w, z] of the e-th component of the error norms (N_Y - 2 of them: q, qd
   and the controller states z, not the works w). */
static inline int error_component(int N_MOTION, int e)
{
    return e < N_MOTION ? e : e + 2;
}

/* The outcome of Newton's iterations on one step (radau_newton). */
enum radau_newton { RADAU_CONVERGED, RADAU_DIVERGED, RADAU_SLOW };

/* Simplified Newton for the stage increments z (3 x N_Y) of the step (t, y) -> t + h, from their
   starting values in z and w = TI z (3 x N_Y each, both updated), with the factored matrices m;
   rates: room for the stages' rates (3 x N_Y). scale (N_Y - 2, see error_component): the error weights; tolerance:
   the iterations' stopping tolerance. *theta: the last contraction rate (RADAU_KEEP_JACOBIAN when
   one iteration sufficed), *faccon: Hairer's theta / (1 - theta), carried from step to step;
   *iterations: the iterations done. On RADAU_SLOW, *shrink: the step's factor Hairer's estimate
   predicts convergence at. *status: the status of a failed rate (else left as it was). */
static enum radau_newton radau_newton(const struct gpmegen_model *model, int N_Y, double t, double h, const double *y,
                                      double z[][N_Y], double w[][N_Y], const struct radau_matrices *m,
                                      const double *scale, double tolerance, const double *p, double rates[][N_Y],
                                      double *theta, double *faccon, int *iterations, double *shrink, long *counts,
                                      int *status)
{
    const int N_MOTION = 2 * model->n_dof, N_ERROR = N_Y - 2;
    const double nodes[3] ALIGNED = { RADAU_C1, RADAU_C2, 1.0 };
    double ys[N_Y] ALIGNED, dw[3][N_Y] ALIGNED, previous = 0.0, previous_rate = 0.0;
    *faccon = pow(fmax(*faccon, DBL_EPSILON), 0.8);
    *theta = RADAU_KEEP_JACOBIAN;
    for (int newt = 1;; ++newt) {
        if (newt > RADAU_ITERATIONS) {
            return RADAU_DIVERGED;
        }
        for (int k = 0; k < 3; ++k) {
            for (int i = 0; i < N_Y; ++i) {
                ys[i] = y[i] + z[k][i];
            }
            ++counts[2];
            if ((*status = gpmegen_state_rate(model, t + nodes[k] * h, ys, p, rates[k])) != GPMEGEN_OK) {
                return RADAU_DIVERGED;
            }
        }
        /* the transformed residual: TI f(z) - Lambda / h w, then the two solves */
        for (int i = 0; i < N_Y; ++i) {
            for (int k = 0; k < 3; ++k) {
                dw[k][i] = RADAU_TI[k][0] * rates[0][i] + RADAU_TI[k][1] * rates[1][i] + RADAU_TI[k][2] * rates[2][i];
            }
            dw[0][i] -= m->s_real * w[0][i];
            dw[1][i] -= m->s_re * w[1][i] - m->s_im * w[2][i];
            dw[2][i] -= m->s_re * w[2][i] + m->s_im * w[1][i];
        }
        radau_solve_real(m, dw[0]);
        radau_solve_complex(m, dw[1], dw[2]);
        double size = 0.0;
        for (int k = 0; k < 3; ++k) {
            for (int e = 0; e < N_ERROR; ++e) {
                const int i = error_component(N_MOTION, e);
                size += (dw[k][i] / scale[e]) * (dw[k][i] / scale[e]);
            }
        }
        size = sqrt(size / (3 * N_ERROR));
        *iterations = newt;
        if (!isfinite(size)) {
            return RADAU_DIVERGED;
        }
        if (newt > 1 && newt < RADAU_ITERATIONS) {
            const double rate = size / previous;
            *theta = newt == 2 ? rate : sqrt(rate * previous_rate);
            previous_rate = rate;
            if (*theta >= 0.99) {
                return RADAU_DIVERGED;
            }
            *faccon = *theta / (1.0 - *theta);
            /* the error left after the iterations still allowed, if they go on contracting so */
            const double left = *faccon * size * pow(*theta, RADAU_ITERATIONS - 1 - newt) / tolerance;
            if (left >= 1.0) {
                *shrink = 0.8 * pow(fmax(1e-4, fmin(20.0, left)), -1.0 / (4 + RADAU_ITERATIONS - 1 - newt));
                return RADAU_SLOW;
            }
        }
        previous = fmax(size, DBL_EPSILON);
        for (int i = 0; i < N_Y; ++i) {
            for (int k = 0; k < 3; ++k) {
                w[k][i] += dw[k][i];
            }
            for (int k = 0; k < 3; ++k) {
                z[k][i] = RADAU_T[k][0] * w[0][i] + RADAU_T[k][1] * w[1][i] + RADAU_T[k][2] * w[2][i];
            }
        }
        if (*faccon * size <= tolerance) {
            return RADAU_CONVERGED;
        }
    }
}

/* What a call of radau that stopped before its last saved instant (max_steps spent) leaves for
   the next to go on from, bit for bit as if it had not stopped (see gpmegen_dop853): the
   Jacobian and the LUs kept, the last step's collocation polynomial (cont), the state and its
   rate, and the step control's memory. started: 0 (all zero bytes) before a span's first call.
   The memory holds a struct radau_place, then the doubles of radau_kept_doubles() (A_qd, N_DOF x
   N_DOF; real, re, im, N_R x N_R each (N_R = N_DOF + N_Z); A_q, N_DOF x N_DOF; A_z, R_q, R_qd,
   N_DOF x N_Z each; R_z, N_Z x N_Z; y, f0, N_Y each; cont, 3 x N_Y), then the pivots (2 x N_R). */
struct radau_place {
    double t, h_factored, h_cont, h_accepted, err_accepted, theta, faccon, s_real, s_re, s_im;
    long k;
    int have_jacobian, fresh_jacobian, have_cont, rejected, accepted, failure, chosen, started;
};

static size_t radau_kept_doubles(int n_dof, int n_z)
{
    const size_t n = (size_t)n_dof, z = (size_t)n_z, r = n + z;
    return 2 * n * n + 3 * r * r + 3 * n * z + z * z + 5 * (2 * n + 2 + z);
}

/* The bytes of the memory, which the caller holds between calls. */
long gpmegen_radau_memory_bytes(const struct gpmegen_model *model)
{
    return (long)(sizeof(struct radau_place)
                  + radau_kept_doubles(model->n_dof, model->n_controllers) * sizeof(double)
                  + 2 * (size_t)(model->n_dof + model->n_controllers) * sizeof(int));
}

/* Radau IIA of order 5 from t_a and y_a = [q, qd, w, z] (N_Y; z the controller states, integrated
   with the motion in the same implicit system) to t_save[n_save - 1], saving y at the
   n_save increasing instants t_save (after t_a) into y_out (n_save x N_Y): the step's own state
   where a step ends on one (always the last), radau_dense_value between. Hairer's
   RADAU5: simplified Newton in the transformed real and complex systems (reduced to N_DOF + N_Z
   ones, struct radau_matrices), from the previous step's collocation polynomial; the embedded error
   estimate filtered by (GAMMA / h I - J)^-1 (and, on the first step or after a rejection,
   once more through a rate), in the root mean square over q, qd and z of err / (atol' + rtol' |y|)
   below 1, with rtol' = 1e-3^(1/5) rtol^(4/5), atol' = atol rtol' / rtol: the estimate is
   O(h^4), the error it leaves after many steps O(h^5), so the latter follows rtol (Hairer's
   0.1 rtol^(2/3), equal at rtol 1e-3, counts the local error, O(h^6), and let the error against
   an exact linear motion grow from 2 to 40 rtol between rtol 1e-4 and 1e-10; this one keeps it
   at 1.6 to 3 rtol); Gustafsson's predictive step control; the
   Jacobian of gpmegen_state_jacobian (the controller states' blocks by differences) kept while
   Newton contracts fast, the LUs while the step is kept.
   *h, max_steps, memory (gpmegen_radau_memory_bytes()) and counts (5: steps, rejected steps (by the
   error or Newton's failure), GPME solves, Jacobians, LU factorizations, the real and the
   complex one each counting) as for dop853.
   Returns GPMEGEN_OK; GPMEGEN_NO_CONVERGENCE when Newton fails on steps down to round-off of t,
   the status of a failed rate or factorization when those did, GPMEGEN_STEP_TOO_SMALL when the
   error test did; GPMEGEN_NONFINITE at a non-finite state or error; GPMEGEN_BAD_ARGUMENTS.
   *n_saved counts the saved rows, also on a failure. */
int gpmegen_radau(const struct gpmegen_model *model, double t_a, const double *y_a, long n_save, const double *t_save,
                  double rtol, double atol, double *h, long max_steps, void *memory, const double *p, double *y_out,
                  long *n_saved, long *counts)
{
    const int N_DOF = model->n_dof, N_Z = model->n_controllers, N_R = N_DOF + N_Z;
    const int N_Y = 2 * N_DOF + 2 + N_Z, N_MOTION = 2 * N_DOF, N_ERROR = N_Y - 2;
    const size_t n_kept = radau_kept_doubles(N_DOF, N_Z), nn = (size_t)N_DOF * (size_t)N_DOF;
    const size_t rr = (size_t)N_R * (size_t)N_R, nz = (size_t)N_DOF * (size_t)N_Z;
    const size_t kept_bytes = n_kept * sizeof(double), pivot_bytes = 2 * (size_t)N_R * sizeof(int);
    struct radau_place run;
    double kept[n_kept] ALIGNED;
    int kept_pivots[2 * N_R] ALIGNED;
    double *const A_q = kept + nn + 3 * rr, *const A_z = A_q + nn, *const R_q = A_z + nz, *const R_qd = R_q + nz;
    double *const R_z = R_qd + nz, *const y = R_z + (size_t)N_Z * (size_t)N_Z, *const f0 = y + N_Y;
    struct radau_matrices matrices = { N_DOF, N_Z, kept, kept + nn, kept + nn + rr, kept + nn + 2 * rr,
                                       A_z, R_q, R_qd, R_z, kept_pivots, kept_pivots + N_R, 0.0, 0.0, 0.0 };
    double qdd[N_DOF] ALIGNED, y_new[N_Y] ALIGNED, scale[N_ERROR] ALIGNED;
    double z[3][N_Y] ALIGNED, w[3][N_Y] ALIGNED, rates[3][N_Y] ALIGNED;
    double err[N_Y] ALIGNED, ys[N_Y] ALIGNED;
    double (*const cont)[N_Y] = (double (*)[N_Y])(f0 + N_Y);
    double t = t_a, h_factored = 0.0, h_cont = 0.0, h_accepted = 0.0, err_accepted = 0.0;
    double theta = 0.0, faccon = 1.0;
    int status, have_jacobian = 0, fresh_jacobian = 0, have_cont = 0, rejected = 0, accepted = 0;
    int failure = GPMEGEN_STEP_TOO_SMALL, chosen = !(*h > 0.0);  /* chosen: the first step is a guess */
    long k = 0, taken = 0;

    *n_saved = 0;
    if (n_save < 1 || !isfinite(t_a) || !(rtol > 0.0) || !(atol >= 0.0) || !isfinite(*h) || max_steps < 0
        || (max_steps > 0 && memory == NULL)) {
        return GPMEGEN_BAD_ARGUMENTS;
    }
    for (long j = 0; j < n_save; ++j) {
        if (!isfinite(t_save[j]) || !(t_save[j] > (j ? t_save[j - 1] : t_a))) {
            return GPMEGEN_BAD_ARGUMENTS;
        }
    }
    const double t_b = t_save[n_save - 1], tol = pow(1e-3, 0.2) * pow(rtol, 0.8), abs_tol = atol * tol / rtol;
    const double newton_tolerance = fmax(10.0 * DBL_EPSILON / tol, fmin(0.03, sqrt(tol)));
    if (memory != NULL) {
        memcpy(&run, memory, sizeof run);
        memcpy(kept, (const char *)memory + sizeof run, kept_bytes);
        memcpy(kept_pivots, (const char *)memory + sizeof run + kept_bytes, pivot_bytes);
        matrices.s_real = run.s_real, matrices.s_re = run.s_re, matrices.s_im = run.s_im;
    } else {
        run.started = 0;
    }
    if (run.started) {  /* going on from the call before: its place, as it kept it */
        if (!(run.k >= 0 && run.k < n_save && run.t >= t_a && run.t < t_b)) {
            return GPMEGEN_BAD_ARGUMENTS;
        }
        t = run.t, h_factored = run.h_factored, h_cont = run.h_cont, h_accepted = run.h_accepted;
        err_accepted = run.err_accepted, theta = run.theta, faccon = run.faccon;
        have_jacobian = run.have_jacobian, fresh_jacobian = run.fresh_jacobian, have_cont = run.have_cont;
        rejected = run.rejected, accepted = run.accepted, failure = run.failure, chosen = run.chosen, k = run.k;
        *n_saved = k;
    } else {
        for (int i = 0; i < N_Y; ++i) {
            y[i] = y_a[i];
        }
        if (!all_finite(y, N_Y)) {
            return GPMEGEN_NONFINITE;
        }
        ++counts[2];
        if ((status = gpmegen_state_rate(model, t, y, p, f0)) != GPMEGEN_OK) {
            return status;
        }
        if (chosen
            && (status = gpmegen_first_step(model, t, y, f0, rtol, atol, t_b - t_a, p, h, &counts[2])) != GPMEGEN_OK) {
            return status;
        }
    }
    while (k < n_save) {
        if (max_steps > 0 && taken == max_steps) {  /* the caller's turn: the place kept for the next call */
            run.t = t, run.h_factored = h_factored, run.h_cont = h_cont, run.h_accepted = h_accepted;
            run.err_accepted = err_accepted, run.theta = theta, run.faccon = faccon;
            run.have_jacobian = have_jacobian, run.fresh_jacobian = fresh_jacobian, run.have_cont = have_cont;
            run.rejected = rejected, run.accepted = accepted, run.failure = failure, run.chosen = chosen, run.k = k;
            run.s_real = matrices.s_real, run.s_re = matrices.s_re, run.s_im = matrices.s_im;
            run.started = 1;
            memcpy(memory, &run, sizeof run);
            memcpy((char *)memory + sizeof run, kept, kept_bytes);
            memcpy((char *)memory + sizeof run + kept_bytes, kept_pivots, pivot_bytes);
            return GPMEGEN_OK;
        }
        ++taken;
        const int last = t + *h >= t_b;
        const double step = last ? t_b - t : *h;
        const double t_new = last ? t_b : t + step;
        if (step <= 10.0 * (nextafter(t, INFINITY) - t)) {
            return failure;
        }
        if (!have_jacobian) {
            counts[2] += gpmegen_state_jacobian_solves(model);
            ++counts[3];
            if ((status = gpmegen_state_jacobian(model, t, y, p, qdd, A_q, matrices.A_qd, A_z, R_q, R_qd, R_z))
                != GPMEGEN_OK) {
                return status;
            }
            have_jacobian = fresh_jacobian = 1;
            h_factored = 0.0;
        }
        double shrink = 0.5;  /* the step's factor after Newton's failure */
        int iterations = 0;
        enum radau_newton newton = RADAU_DIVERGED;
        if (step != h_factored) {
            counts[4] += 2;
            h_factored = (status = radau_factor(step, A_q, &matrices)) == GPMEGEN_OK ? step : 0.0;
        }
        if (h_factored == step) {
            for (int e = 0; e < N_ERROR; ++e) {
                const double y_e = y[error_component(N_MOTION, e)];
                scale[e] = error_scale(tol, abs_tol, y_e, y_e);
            }
            /* the starting values: the last step's collocation polynomial, extrapolated */
            for (int s = 0; s < 3; ++s) {
                const double x = (s == 0 ? RADAU_C1 : s == 1 ? RADAU_C2 : 1.0) * step / (have_cont ? h_cont : 1.0);
                for (int i = 0; i < N_Y; ++i) {
                    z[s][i] = have_cont ? x * (cont[0][i] + (x - RADAU_C2 + 1.0) * (cont[1][i]
                                                            + (x - RADAU_C1 + 1.0) * cont[2][i])) : 0.0;
                }
            }
            for (int i = 0; i < N_Y; ++i) {
                for (int s = 0; s < 3; ++s) {
                    w[s][i] = RADAU_TI[s][0] * z[0][i] + RADAU_TI[s][1] * z[1][i] + RADAU_TI[s][2] * z[2][i];
                }
            }
            newton = radau_newton(model, N_Y, t, step, y, z, w, &matrices, scale, newton_tolerance, p, rates,
                                  &theta, &faccon, &iterations, &shrink, counts, &status);
            failure = newton == RADAU_CONVERGED ? failure : status != GPMEGEN_OK ? status : GPMEGEN_NO_CONVERGENCE;
        } else {
            failure = status;
        }
        if (newton != RADAU_CONVERGED) {  /* Hairer's unexpected rejection: a shorter step */
            *h = step * shrink;
            ++counts[1];
            rejected = 1;
            have_jacobian = fresh_jacobian;
            continue;
        }
        /* the error estimate (GAMMA / h I - J)^-1 (f0 + sum_s E_s z_s / h), once more through a
           rate at y + err when it fails on the first step or after a rejection */
        double error = 0.0;
        for (int pass = 0; pass < 2; ++pass) {
            for (int i = 0; i < N_Y; ++i) {
                const double e = (RADAU_E[0] * z[0][i] + RADAU_E[1] * z[1][i] + RADAU_E[2] * z[2][i]) / step;
                err[i] = (pass ? ys[i] : f0[i]) + e;
            }
            radau_solve_real(&matrices, err);
            error = 0.0;
            for (int e = 0; e < N_ERROR; ++e) {
                const int i = error_component(N_MOTION, e);
                error += (err[i] / scale[e]) * (err[i] / scale[e]);
            }
            error = fmax(sqrt(error / N_ERROR), 1e-10);
            if (pass || error < 1.0 || !((chosen && accepted == 0) || rejected) || !isfinite(error)) {
                break;
            }
            for (int i = 0; i < N_Y; ++i) {
                y_new[i] = y[i] + err[i];
            }
            ++counts[2];
            if ((status = gpmegen_state_rate(model, t, y_new, p, ys)) != GPMEGEN_OK) {
                return status;
            }
        }
        if (!isfinite(error)) {
            return GPMEGEN_NONFINITE;
        }
        /* the new step: Hairer's safety factor, lower when Newton needed many iterations */
        const double safety = fmin(RADAU_SAFETY, RADAU_SAFETY * (1 + 2 * RADAU_ITERATIONS)
                                                 / (iterations + 2 * RADAU_ITERATIONS));
        double quotient = fmax(1.0 / RADAU_GROWTH, fmin(1.0 / RADAU_SHRINK, pow(error, 0.25) / safety));
        if (error >= 1.0) {
            *h = chosen && accepted == 0 ? 0.1 * step : step / quotient;
            ++counts[1];
            rejected = 1;
            /* Hairer refreshes the Jacobian after any rejection; Newton contracted fast with this
               one, so only the error test failed: kept (at n_rfe 20 the refreshes after such
               rejections were nine tenths of the solves) */
            have_jacobian = fresh_jacobian || theta <= RADAU_KEEP_JACOBIAN;
            failure = GPMEGEN_STEP_TOO_SMALL;
            continue;
        }
        if (accepted > 0) {  /* Gustafsson's predictive control */
            const double predicted = h_accepted / step * pow(error * error / err_accepted, 0.25) / RADAU_SAFETY;
            quotient = fmax(quotient, fmax(1.0 / RADAU_GROWTH, fmin(1.0 / RADAU_SHRINK, predicted)));
        }
        h_accepted = step;
        err_accepted = fmax(1e-2, error);
        for (int i = 0; i < N_Y; ++i) {
            y_new[i] = y[i] + z[2][i];
            /* the collocation polynomial through y and the stages (Hairer's CONTR5 form): the next
               step's starting values */
            const double z1 = z[0][i], z2 = z[1][i], z3 = z[2][i];
            const double ak = (z1 - z2) / (RADAU_C1 - RADAU_C2);
            const double acont3 = (ak - z1 / RADAU_C1) / RADAU_C2;
            cont[0][i] = (z2 - z3) / (RADAU_C2 - 1.0);
            cont[1][i] = (ak - cont[0][i]) / (RADAU_C1 - 1.0);
            cont[2][i] = cont[1][i] - acont3;
        }
        if (!all_finite(y_new, N_Y)) {
            return GPMEGEN_NONFINITE;
        }
        double h_next = step / quotient;
        if (rejected) {
            h_next = fmin(h_next, step);
        }
        /* keep the step, and so the LUs, when it would barely grow; keep the Jacobian while
           Newton contracts fast */
        if (theta <= RADAU_KEEP_JACOBIAN && h_next >= step && h_next <= RADAU_KEEP_STEP * step) {
            h_next = step;
        }
        have_jacobian = theta <= RADAU_KEEP_JACOBIAN;
        fresh_jacobian = 0;
        /* a step cut short to end on t_b says nothing against the longer one it replaced */
        *h = last ? fmax(*h, h_next) : h_next;
        rejected = 0;
        failure = GPMEGEN_STEP_TOO_SMALL;
        ++accepted;
        ++counts[0];
        int dense = 0;
        for (; k < n_save && t_save[k] <= t_new; ++k) {
            if (t_save[k] == t_new) {
                for (int i = 0; i < N_Y; ++i) {
                    y_out[k * N_Y + i] = y_new[i];
                }
                continue;
            }
            if (!dense) {
                radau_stage_rates(N_Y, (const double (*)[N_Y])w, rates);
                dense = 1;
            }
            radau_dense_value(N_Y, (t_save[k] - t) / step, step, y, f0, (const double (*)[N_Y])rates, y_out + k * N_Y);
        }
        *n_saved = k;
        ++counts[2];
        if ((status = gpmegen_state_rate(model, t_new, y_new, p, f0)) != GPMEGEN_OK) {
            return status;
        }
        t = t_new;
        h_cont = step;
        have_cont = 1;
        for (int i = 0; i < N_Y; ++i) {
            y[i] = y_new[i];
        }
    }
    return GPMEGEN_OK;
}
