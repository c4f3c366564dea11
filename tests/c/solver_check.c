/* The solver library (gpmegen/csrc) on hand-written models with known answers, linked with its
   object as a model library links it (tests/test_c_solver.py compiles and runs this program, also
   under the sanitizers). Prints one line per check, "ok NAME" or "FAIL NAME: ...", and exits with
   the number of failures.

   The models: two undamped oscillators, qdd_i = -(k_i / m_i) q_i (no constraints; exact motion
   q_i(t) = q_i(0) cos(omega_i t), omega_i^2 = k_i / m_i), and the same two masses tied by one
   position constraint q_0 - q_1 = 0 (one oscillator of mass m_0 + m_1 and stiffness k_0 + k_1). */

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "solver_internal.h"  /* also the LU and the Jacobians' solve count */

static const double MASS[2] = {1.0, 3.0}, STIFFNESS[2] = {4.0, 2.0};
static int failures;

static void check(const char *name, int ok, const char *what, double value)
{
    if (ok) {
        printf("ok %s\n", name);
    } else {
        printf("FAIL %s: %s %.17g\n", name, what, value);
        ++failures;
    }
}

/* M = diag(MASS), f = -diag(STIFFNESS) q; with the constraint: phi = q0 - q1, D = [1, -1]. */
static void gpme_terms(double t, const double *q, const double *qd, const double *p, double *M, double *f,
                       double *phi, double *phi_rate, double *D, double *gamma, int constrained)
{
    (void)t;
    (void)p;
    M[0] = MASS[0], M[1] = 0.0, M[2] = 0.0, M[3] = MASS[1];
    f[0] = -STIFFNESS[0] * q[0], f[1] = -STIFFNESS[1] * q[1];
    if (constrained) {
        phi[0] = q[0] - q[1], phi_rate[0] = qd[0] - qd[1], D[0] = 1.0, D[1] = -1.0, gamma[0] = 0.0;
    }
}

static void free_terms(double t, const double *q, const double *qd, const double *p, double *M, double *f,
                       double *phi, double *phi_rate, double *D, double *gamma)
{
    gpme_terms(t, q, qd, p, M, f, phi, phi_rate, D, gamma, 0);
}

static void tied_terms(double t, const double *q, const double *qd, const double *p, double *M, double *f,
                       double *phi, double *phi_rate, double *D, double *gamma)
{
    gpme_terms(t, q, qd, p, M, f, phi, phi_rate, D, gamma, 1);
}

static void tied_constraint_terms(double t, const double *q, const double *qd, const double *p, double *phi,
                                  double *phi_rate, double *D, double *gamma)
{
    double M[4], f[2];
    tied_terms(t, q, qd, p, M, f, phi, phi_rate, D, gamma);
}

static void no_constraint_terms(double t, const double *q, const double *qd, const double *p, double *phi,
                                double *phi_rate, double *D, double *gamma)
{
    (void)t, (void)q, (void)qd, (void)p, (void)phi, (void)phi_rate, (void)D, (void)gamma;
}

static void gains(const double *p, double *alpha, double *beta)
{
    (void)p;
    alpha[0] = 0.0, beta[0] = 0.0;
}

static void no_gains(const double *p, double *alpha, double *beta)
{
    (void)p, (void)alpha, (void)beta;
}

static void no_drive(double t, const double *q, const double *qd, const double *p, double *Q)
{
    (void)t, (void)q, (void)qd, (void)p;
    Q[0] = 0.0, Q[1] = 0.0;
}

static const int ORDERS[1] = {0};
static const struct gpmegen_model FREE, TIED;

/* The model's own solve, as a generated recursion would give it: here the dense solve. */
static int free_recursive(double t, const double *q, const double *qd, const double *p, double *qdd, double *power)
{
    double M[4], f[2];
    return gpmegen_gpme_solve(&FREE, t, q, qd, p, qdd, M, f, power);
}

static int tied_recursive(double t, const double *q, const double *qd, const double *p, double *qdd, double *power)
{
    double M[4], f[2];
    return gpmegen_gpme_solve(&TIED, t, q, qd, p, qdd, M, f, power);
}

static const struct gpmegen_model FREE = {2, 0, NULL, free_terms, no_constraint_terms, no_gains, no_drive,
                                          free_recursive, NULL, 0};
static const struct gpmegen_model TIED = {2, 1, ORDERS, tied_terms, tied_constraint_terms, gains, no_drive,
                                          tied_recursive, NULL, 0};

/* The largest error of q against the exact motion at t from q(0) = q0, qd(0) = 0. */
static double motion_error(const struct gpmegen_model *model, const double *q, double t, const double *q0)
{
    double error = 0.0;
    for (int i = 0; i < 2; ++i) {
        const double omega = model->n_constraints ? sqrt((STIFFNESS[0] + STIFFNESS[1]) / (MASS[0] + MASS[1]))
                                                  : sqrt(STIFFNESS[i] / MASS[i]);
        error = fmax(error, fabs(q[i] - q0[i] * cos(omega * t)));
    }
    return error;
}

static double rk4_error(const struct gpmegen_model *model, long n_steps, double t_end, const double *q0)
{
    const double qd0[2] = {0.0, 0.0}, w0[2] = {0.0, 0.0}, p[1] = {0.0};
    double t_out[2], q_out[4], qd_out[4], w_out[4];
    long saved;
    const int status = gpmegen_rk4(model, 0.0, t_end / (double)n_steps, n_steps, t_end, 0, n_steps, n_steps, q0, qd0,
                                   w0, p, t_out, q_out, qd_out, w_out, &saved);
    return status == GPMEGEN_OK && saved == 2 ? motion_error(model, q_out + 2, t_end, q0) : INFINITY;
}

static double genalpha_error(const struct gpmegen_model *model, long n_steps, double t_end, const double *q0)
{
    double y[6] = {q0[0], q0[1], 0.0, 0.0, 0.0, 0.0}, a[4] = {NAN, NAN, NAN, NAN}, S[4], y_out[6];   /* a: 2 N_DOF */
    const double p[1] = {0.0};
    int pivot[2], have_matrix = 0;
    long saved, counts[6] = {0};
    const int status = gpmegen_genalpha(model, 0.0, t_end / (double)n_steps, n_steps, t_end, 0, n_steps, 0.9, 1, y, a,
                                        S, pivot, &have_matrix, 1, &t_end, p, y_out, &saved, counts);
    return status == GPMEGEN_OK && saved == 1 ? motion_error(model, y_out, t_end, q0) : INFINITY;
}

/* DOP853 or Radau to t_end at rtol, in chunks of 7 steps when chunked (the memory carries the
   run across calls): the error against the exact motion, and the final state into y_end. */
static double adaptive_error(const struct gpmegen_model *model, int radau, double rtol, int chunked, double t_end,
                             const double *q0, double *y_end)
{
    const double y0[6] = {q0[0], q0[1], 0.0, 0.0, 0.0, 0.0}, p[1] = {0.0};
    const long bytes = radau ? gpmegen_radau_memory_bytes(model) : gpmegen_dop853_memory_bytes(model);
    double memory[4096];
    double h = 0.0;
    long saved = 0, counts[5] = {0};
    int status;
    if ((size_t)bytes > sizeof memory) {
        return INFINITY;
    }
    memset(memory, 0, sizeof memory);
    do {
        status = (radau ? gpmegen_radau : gpmegen_dop853)(model, 0.0, y0, 1, &t_end, rtol, 1e-12, &h, chunked ? 7 : 0,
                                                          memory, p, y_end, &saved, counts);
    } while (status == GPMEGEN_OK && saved < 1);
    return status == GPMEGEN_OK ? motion_error(model, y_end, t_end, q0) : INFINITY;
}

int main(void)
{
    const double q0[2] = {0.3, -0.2}, tied_q0[2] = {0.25, 0.25};
    char name[64];

    /* the factorizations on a known system: [[4, 2, 0], [2, 5, 1], [0, 1, 3]] x = [2, 1, 4] */
    {
        const double A[9] = {4, 2, 0, 2, 5, 1, 0, 1, 3}, b[3] = {2, 1, 4};
        double L[9], inv_d[3], x[3], LU[9];
        int piv[3];
        memcpy(L, A, sizeof A), memcpy(LU, A, sizeof A), memcpy(x, b, sizeof b);
        int ok = gpmegen_ldlt(3, L, inv_d) == GPMEGEN_OK;
        gpmegen_ldlt_solve(3, L, inv_d, x);
        double residual = 0.0;
        for (int i = 0; i < 3; ++i) {
            residual = fmax(residual, fabs(A[3 * i] * x[0] + A[3 * i + 1] * x[1] + A[3 * i + 2] * x[2] - b[i]));
        }
        check("ldlt", ok && residual < 1e-14, "residual", residual);
        memcpy(x, b, sizeof b);
        ok = gpmegen_lu_factor(3, LU, piv) == GPMEGEN_OK;
        gpmegen_lu_solve(3, LU, piv, 1, x);
        residual = 0.0;
        for (int i = 0; i < 3; ++i) {
            residual = fmax(residual, fabs(A[3 * i] * x[0] + A[3 * i + 1] * x[1] + A[3 * i + 2] * x[2] - b[i]));
        }
        check("lu", ok && residual < 1e-14, "residual", residual);
        double singular[4] = {1.0, 2.0, 2.0, 4.0};
        check("ldlt_singular", gpmegen_ldlt(2, singular, inv_d) == GPMEGEN_SINGULAR, "status", 0.0);
    }
    /* the dense solve: tied masses at q = (1, 1) accelerate together, (f0 + f1) / (m0 + m1) */
    {
        const double q[2] = {1.0, 1.0}, qd[2] = {0.5, 0.5}, p[1] = {0.0};
        double qdd[2], M[4], f[2], power;
        const int status = gpmegen_gpme_solve(&TIED, 0.0, q, qd, p, qdd, M, f, &power);
        const double expected = -(STIFFNESS[0] + STIFFNESS[1]) / (MASS[0] + MASS[1]);
        const double error = fmax(fabs(qdd[0] - expected), fabs(qdd[1] - expected));
        check("gpme_solve_tied", status == GPMEGEN_OK && error < 1e-15 && fabs(power) < 1e-15, "error", error);
        gpmegen_gpme_solve(&FREE, 0.0, q, qd, p, qdd, M, f, &power);
        check("gpme_solve_free", qdd[0] == -STIFFNESS[0] / MASS[0] && qdd[1] == -STIFFNESS[1] / MASS[1], "qdd0",
              qdd[0]);
    }
    /* the Jacobians by differences: dqdd/dq = -diag(k / m), dqdd/dqd = 0 */
    {
        const double q[2] = {0.1, -0.4}, qd[2] = {0.0, 0.0}, p[1] = {0.0};
        double qdd[2], J_q[4], J_qd[4];
        const int status = gpmegen_gpme_jacobian(&FREE, 0.0, q, qd, p, qdd, J_q, J_qd);
        const double expected[4] = {-STIFFNESS[0] / MASS[0], 0.0, 0.0, -STIFFNESS[1] / MASS[1]};
        double error = 0.0;
        for (int i = 0; i < 4; ++i) {
            error = fmax(error, fmax(fabs(J_q[i] - expected[i]), fabs(J_qd[i])));
        }
        check("jacobian_differences", status == GPMEGEN_OK && error < 1e-8, "error", error);
        check("jacobian_solves", gpmegen_jacobian_solves(&FREE) == 9, "solves", (double)gpmegen_jacobian_solves(&FREE));
    }
    /* RK4 converges at order 4, generalized-alpha at order 2, on both models */
    for (int tied = 0; tied < 2; ++tied) {
        const struct gpmegen_model *model = tied ? &TIED : &FREE;
        const double *start = tied ? tied_q0 : q0;
        const double coarse = rk4_error(model, 50, 2.0, start), fine = rk4_error(model, 100, 2.0, start);
        snprintf(name, sizeof name, "rk4_order_%s", tied ? "tied" : "free");
        check(name, fine > 0.0 && coarse / fine > 14.0 && coarse / fine < 18.0, "error ratio", coarse / fine);
        const double ga_coarse = genalpha_error(model, 200, 2.0, start);
        const double ga_fine = genalpha_error(model, 400, 2.0, start);
        snprintf(name, sizeof name, "genalpha_order_%s", tied ? "tied" : "free");
        check(name, ga_fine > 0.0 && ga_coarse / ga_fine > 3.5 && ga_coarse / ga_fine < 4.5, "error ratio",
              ga_coarse / ga_fine);
    }
    /* DOP853 and Radau keep the error near rtol, and a run in chunks ends on the same bits */
    for (int radau = 0; radau < 2; ++radau) {
        for (int tied = 0; tied < 2; ++tied) {
            const struct gpmegen_model *model = tied ? &TIED : &FREE;
            const double *start = tied ? tied_q0 : q0;
            double whole[6], chunks[6];
            const double error = adaptive_error(model, radau, 1e-9, 0, 2.0, start, whole);
            snprintf(name, sizeof name, "%s_accuracy_%s", radau ? "radau" : "dop853", tied ? "tied" : "free");
            check(name, error < 1e-7, "error", error);
            adaptive_error(model, radau, 1e-9, 1, 2.0, start, chunks);
            snprintf(name, sizeof name, "%s_chunks_%s", radau ? "radau" : "dop853", tied ? "tied" : "free");
            check(name, memcmp(whole, chunks, sizeof whole) == 0, "q0 difference", whole[0] - chunks[0]);
        }
    }
    return failures;
}
