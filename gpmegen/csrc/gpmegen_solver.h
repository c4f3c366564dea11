/* gpmegen's solver library: the hand-written C that every model shares (the GPME's dense solve,
   RK4, DOP853, generalized-alpha, Radau IIA, the acceleration Jacobians). It is compiled once per
   machine and flags into the C cache (gpmegen.runtime.ccompile) and linked into each model's
   library, whose generated model.c fills a struct gpmegen_model with its sizes and its generated
   functions and exports thin wrappers (model.h) that pass it to the functions below.

   Every array is row-major and owned by the caller. The functions are hidden: a model library
   calls them, and exports only its own names. */

#ifndef GPMEGEN_SOLVER_H
#define GPMEGEN_SOLVER_H

#include <float.h>
#include <math.h>

#ifndef GPMEGEN_STATUS
#define GPMEGEN_STATUS
/* What the solves and integrators return: gpmegen.status.SolveStatus (a test compares them). */
enum gpmegen_status {
    GPMEGEN_OK = 0,
    GPMEGEN_SINGULAR = 1,
    GPMEGEN_NONFINITE = 2,
    GPMEGEN_BAD_ARGUMENTS = 3,
    GPMEGEN_STEP_TOO_SMALL = 4,
    GPMEGEN_NO_CONVERGENCE = 5
};
#endif

#if defined(__GNUC__)
#define GPMEGEN_HIDDEN __attribute__((visibility("hidden")))
#else
#define GPMEGEN_HIDDEN
#endif

/* A model as the library sees it: its sizes and its generated functions (the shapes as model.h
   documents them for the model's exported functions of the same names). */
struct gpmegen_model {
    int n_dof, n_constraints;
    /* order of each programmed constraint (n_constraints): 0 position (Baumgarte 2 alpha,
       beta^2), 1 first order (alpha), 2 second order (no gains) */
    const int *constraint_orders;
    /* M (n_dof x n_dof), f (n_dof) and the constraint terms phi, phi_rate (n_constraints), D
       (n_constraints x n_dof) and gamma (n_constraints) in one pass */
    void (*gpme_terms)(double t, const double *q, const double *qd, const double *p, double *M, double *f,
                       double *phi, double *phi_rate, double *D, double *gamma);
    /* the constraint terms alone */
    void (*constraint_terms)(double t, const double *q, const double *qd, const double *p, double *phi,
                             double *phi_rate, double *D, double *gamma);
    void (*baumgarte_gains)(const double *p, double *alpha, double *beta);
    /* drive forces Q(t, q, qd) (n_dof): the drives' laws, feedback included */
    void (*drive_forces)(double t, const double *q, const double *qd, const double *p, double *Q);
    /* qdd (n_dof) from the GPME in O(n_dof) (the model's own recursion over its tree, which
       falls back to gpmegen_gpme_solve) and *power, that of the constraint forces */
    int (*gpme_recursive)(double t, const double *q, const double *qd, const double *p, double *qdd,
                          double *power);
    /* dF/dq, dF/dqd (n_dof x n_dof), dC/dq, dC/dqd (n_constraints x n_dof) of the GPME residuals
       F = f - M a + D^T lam and C = c - D a; NULL when the model was built without them (the
       Jacobians are then taken by central differences) */
    void (*gpme_residual_jacobians)(double t, const double *q, const double *qd, const double *a,
                                    const double *lam, const double *p, double *F_q, double *F_qd, double *C_q,
                                    double *C_qd);
    /* 1: the constraint rows may be redundant (the model closes loops, whose rows can be more than
       its motion needs): where D loses rank the solves keep its independent rows; 0 (a model
       that closes no loop): D losing rank is singular */
    int redundant_rows;
    /* The controller states z (n_controllers, 0 in a model without, controller_rates then NULL):
       the last entries of p, after its n_parameters parameters, which the generated
       functions read as they read the parameters; every integrator puts each stage's z there and
       integrates z with the motion, as the components of y after the two work integrals (radau
       and genalpha in their Newton iterations, with the rates' Jacobians by differences).
       controller_rates: dz/dt (n_controllers) at (t, q, qd) and the z in p. */
    int n_parameters, n_controllers;
    void (*controller_rates)(double t, const double *q, const double *qd, const double *p, double *z_rate);
    /* The actuated realization (actuated.c): the coordinate of each constraint's input
       (n_constraints), whose stages then solve M qdd = f + S u with the constraint rows in place of
       the GPME (gpmegen_stage); NULL (the model's own descriptor) for the ideal realization. Only
       the model's actuated entries (its single actuated solve, RK4 and DOP853 loops) pass a copy
       of the descriptor with it set. */
    const int *actuators;
};

/* The small kernels that the model's recursion shares with the library's dense solve: defined
   here, so that each is compiled where it is called, in model.c with the model's sizes as
   constants (the recursion solves a system of n_constraints there, in every stage of every
   step), in the library with the sizes of the call (unused where not called). Kept apart from
   their callers (noinline):
   inlined into the solve, the factorization's code pushed the loop out of the instruction cache
   and an RK4 step at n_rfe = 5 took 18% longer. */
#if defined(__GNUC__)
#define GPMEGEN_KERNEL static __attribute__((noinline, unused))
#else
#define GPMEGEN_KERNEL static
#endif

/* LDL^T factorization in place of the symmetric positive definite n x n row-major a, read and
   written in its upper triangle only (a[j * n + i], i >= j): on return a[j * n + i] = L_ij for
   i > j (L unit lower triangular) and inv_d[j] = 1 / D_jj. No square roots, and one division per
   column: the factorization is a chain of n dependent pivots, so what each pivot costs sets
   its time (a Cholesky pivot waits for a square root and then a division). Right-looking
   updates run along contiguous rows. Returns GPMEGEN_NONFINITE when a diagonal entry or a
   pivot is not finite (a non-finite off-diagonal entry reaches a later pivot), GPMEGEN_SINGULAR
   when a is not numerically positive definite (a pivot at or below n * DBL_EPSILON times the
   largest diagonal entry), else GPMEGEN_OK. */
GPMEGEN_KERNEL int gpmegen_ldlt(int n, double *a, double *inv_d)
{
    double scale = 0.0;
    for (int i = 0; i < n; ++i) {
        if (!(fabs(a[i * n + i]) <= DBL_MAX)) {
            return GPMEGEN_NONFINITE;
        }
        if (a[i * n + i] > scale) {
            scale = a[i * n + i];
        }
    }
    const double tiny = (double)n * DBL_EPSILON * scale;
    for (int j = 0; j < n; ++j) {
        double *row = a + j * n;
        const double d = row[j];
        if (!(d > tiny)) {
            return isfinite(d) ? GPMEGEN_SINGULAR : GPMEGEN_NONFINITE;
        }
        const double inv = 1.0 / d;
        inv_d[j] = inv;
        for (int m = j + 1; m < n; ++m) {
            const double l = row[m] * inv;  /* L_mj; row[m] is L_mj D_jj */
            double *target = a + m * n;
            for (int i = m; i < n; ++i) {
                target[i] -= l * row[i];
            }
        }
        for (int i = j + 1; i < n; ++i) {
            row[i] *= inv;
        }
    }
    return GPMEGEN_OK;
}

/* Solve L D L^T x = b in place (b: n entries) with the factors from gpmegen_ldlt(). Both
   substitutions go column by column: once an unknown is final it is taken out of all the others
   at once, so each step waits for one multiply-subtract rather than for a sum run in sequence. */
GPMEGEN_KERNEL void gpmegen_ldlt_solve(int n, const double *a, const double *inv_d, double *b)
{
    for (int k = 0; k < n; ++k) {
        const double y = b[k];
        const double *row = a + k * n;
        for (int i = k + 1; i < n; ++i) {
            b[i] -= row[i] * y;
        }
    }
    for (int i = 0; i < n; ++i) {
        b[i] *= inv_d[i];
    }
    for (int k = n - 1; k > 0; --k) {
        const double x = b[k];
        for (int i = 0; i < k; ++i) {
            b[i] -= a[i * n + k] * x;
        }
    }
}

/* The right sides c (N_CONSTRAINTS) of the constraint rows D qdd = c from their terms phi,
   phi_rate, gam and Baumgarte gains alpha, beta (see gpmegen_gpme_solve). */
static inline void gpmegen_constraint_rhs(const struct gpmegen_model *model, const double *phi,
                                          const double *phi_rate, const double *gam, const double *alpha,
                                          const double *beta, double *c)
{
    const int *orders = model->constraint_orders;
    for (int a = 0; a < model->n_constraints; ++a) {
        c[a] = orders[a] == 0 ? -gam[a] - 2.0 * alpha[a] * phi_rate[a] - beta[a] * beta[a] * phi[a]
             : orders[a] == 1 ? -gam[a] - alpha[a] * phi[a]
             : -gam[a];
    }
}

/* qdd (n_dof) from the GPME by the dense solve, with the M and f it was solved from, and *power. */
GPMEGEN_HIDDEN int gpmegen_gpme_solve(const struct gpmegen_model *model, double t, const double *q,
                                      const double *qd, const double *p, double *qdd, double *M, double *f,
                                      double *power);

/* qdd (n_dof) and the inputs u (n_constraints) of the actuated realization on model->actuators
   (actuated.c), with the M and f they were solved from and *power, that of the inputs. */
GPMEGEN_HIDDEN int gpmegen_actuated_solve(const struct gpmegen_model *model, double t, const double *q,
                                          const double *qd, const double *p, double *qdd, double *u, double *M,
                                          double *f, double *power);

/* The integrators and the Jacobians: the arguments of the model's exported functions of the same
   names (model.h) after the model. */
GPMEGEN_HIDDEN int gpmegen_gpme_jacobian(const struct gpmegen_model *model, double t, const double *q,
                                         const double *qd, const double *p, double *qdd, double *dqdd_dq,
                                         double *dqdd_dqd);
GPMEGEN_HIDDEN int gpmegen_rk4(const struct gpmegen_model *model, double t0, double dt, long n_steps, double t_end,
                               long k_from, long k_to, long save_every, const double *q0, const double *qd0,
                               const double *w0, const double *p, double *t_out, double *q_out, double *qd_out,
                               double *w_out, long *n_saved);
GPMEGEN_HIDDEN long gpmegen_dop853_memory_bytes(const struct gpmegen_model *model);
GPMEGEN_HIDDEN int gpmegen_dop853(const struct gpmegen_model *model, double t_a, const double *y_a, long n_save,
                                  const double *t_save, double rtol, double atol, double *h, long max_steps,
                                  void *memory, const double *p, double *y_out, long *n_saved, long *counts);
GPMEGEN_HIDDEN long gpmegen_radau_memory_bytes(const struct gpmegen_model *model);
GPMEGEN_HIDDEN int gpmegen_radau(const struct gpmegen_model *model, double t_a, const double *y_a, long n_save,
                                 const double *t_save, double rtol, double atol, double *h, long max_steps,
                                 void *memory, const double *p, double *y_out, long *n_saved, long *counts);
GPMEGEN_HIDDEN int gpmegen_genalpha(const struct gpmegen_model *model, double t0, double dt, long n_steps,
                                    double t_end, long k_from, long k_to, double rho_inf, int project, double *y_io,
                                    double *a_io, double *S, int *pivot, int *have_matrix, long n_save,
                                    const double *t_save, const double *p, double *y_out, long *n_saved,
                                    long *counts);

/* Table signals: reference signals of time that a model's drives name, each a table of samples
   (t_k, y_k), t strictly increasing, that the runtime reads from a file and sets before a run
   (gpmegen.runtime.signals); the generated code calls gpmegen_signal(k, t). The value is the
   linear interpolation between the two samples about t (the samples' own values at them), held
   at the ends; NAN for a signal not set. At most GPMEGEN_MAX_SIGNALS (gpmegen.model.chain.
   MAX_SIGNALS) per model library; the tables are the library's (one per process), and only
   pointers are kept: the caller keeps the arrays alive. gpmegen_set_signal returns GPMEGEN_OK, or
   GPMEGEN_BAD_ARGUMENTS (k out of range, n < 2, NULL arrays; n = 0 with NULL arrays unsets). */
#define GPMEGEN_MAX_SIGNALS 32
GPMEGEN_HIDDEN int gpmegen_set_signal(int k, long n, const double *t, const double *y);
GPMEGEN_HIDDEN double gpmegen_signal(int k, double t);

#endif
