/* gpmegen's solver library: the hand-written C that every model shares (the GPME's dense solve,
   RK4, DOP853, generalized-alpha, Radau IIA, the acceleration Jacobians). It is compiled once per
   machine and flags into the C cache (gpmegen.runtime.ccompile) and linked into each model's
   library, whose generated model.c fills a struct gpmegen_model with its sizes and its generated
   functions and exports thin wrappers (model.h) that pass it to the functions below.

   Every array is row-major and owned by the caller. The functions are hidden: a model library
   calls them, and exports only its own names. */

#ifndef GPMEGEN_SOLVER_H
#define GPMEGEN_SOLVER_H

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
    /* drive forces Q(t) (n_dof) */
    void (*drive_forces)(double t, const double *p, double *Q);
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
};

/* LDL^T factorization of the symmetric positive definite n x n a, in its upper triangle, and the
   solve with its factors (gpme.c). */
GPMEGEN_HIDDEN int gpmegen_ldlt(int n, double *a, double *inv_d);
GPMEGEN_HIDDEN void gpmegen_ldlt_solve(int n, const double *a, const double *inv_d, double *b);
/* The right sides c (n_constraints) of the constraint rows D qdd = c from their terms and gains. */
GPMEGEN_HIDDEN void gpmegen_constraint_rhs(const struct gpmegen_model *model, const double *phi,
                                           const double *phi_rate, const double *gam, const double *alpha,
                                           const double *beta, double *c);
/* qdd (n_dof) from the GPME by the dense solve, with the M and f it was solved from, and *power. */
GPMEGEN_HIDDEN int gpmegen_gpme_solve(const struct gpmegen_model *model, double t, const double *q,
                                      const double *qd, const double *p, double *qdd, double *M, double *f,
                                      double *power);

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

#endif
