/* What the solver library's sources share among themselves (not seen by a model's C).

   The sizes come from the model at run time; each function names them as its locals N_DOF,
   N_CONSTRAINTS, N_Y (= 2 N_DOF + 2: q, qd and the work w of drive and constraint forces) and
   N_MOTION (= 2 N_DOF), and sizes its scratch arrays by them (variable-length arrays on the stack,
   as large as the fixed-size ones of a model compiled with its sizes: no allocation). */

#ifndef GPMEGEN_SOLVER_INTERNAL_H
#define GPMEGEN_SOLVER_INTERNAL_H

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "gpmegen_solver.h"

/* Every local array is declared 64-byte aligned: GCC 12.2 at -O3 with AVX-512 tuning vectorizes
   stores into a local array with aligned moves while its stack slot is only 16-byte aligned
   (tests/c/gcc_vectorizer_alignment.c reproduces it). Declared alignment makes the vectorizer's
   assumption true; no arithmetic changes (-DALIGNED= in the flags turns it off). */
#if !defined(ALIGNED) && defined(__GNUC__)
#define ALIGNED __attribute__((aligned(64)))
#elif !defined(ALIGNED)
#define ALIGNED
#endif

#if defined(__GNUC__)
#define NOINLINE __attribute__((noinline))
#define ALWAYS_INLINE __attribute__((always_inline))
#else
#define NOINLINE
#define ALWAYS_INLINE
#endif

/* Below this fraction of the largest entry of D, a pivot of the elimination counts as zero (gpme.c;
   jacobian.c: of the largest row's norm, as gpmegen.runtime.gpme.RANK_TOLERANCE): the rows left
   are combinations of those pivoted (D's rank is the number of pivots before it). It is relative to D's scale, and above the round-off that the elimination leaves in a row that is a
   combination of others (a few N_DOF * DBL_EPSILON of D's largest entry), far below any pivot of
   rows that are independent but nearly dependent that a run could use (their X grows as 1/pivot). */
#define GPMEGEN_RANK_TOLERANCE 1e-10

/* A variable-length array's length: at least 1 (a length of 0 is undefined behaviour). */
#define AT_LEAST_1(n) ((n) > 0 ? (n) : 1)

/* Whether x[0..n-1] are all finite. */
static inline int all_finite(const double *x, int n)
{
    for (int i = 0; i < n; ++i) {
        if (!isfinite(x[i])) {
            return 0;
        }
    }
    return 1;
}

/* Time at the end of step k of the grid, the one gpmegen.runtime.integrators.loop.grid defines: step
   k = 1 .. n_steps ends at t0 + k dt (no accumulated round-off in t), the last at t_end. */
static inline double grid_time(double t0, double dt, long n_steps, double t_end, long k)
{
    return k == n_steps ? t_end : t0 + (double)k * dt;
}

/* The weight of component i in the error norm: atol + rtol max(|y_i|, |y_new_i|). */
static inline double error_scale(double rtol, double atol, double a, double b)
{
    return atol + rtol * fmax(fabs(a), fabs(b));
}

/* rk4.c: one stage's qdd (N_DOF), the powers (2) of drive and constraint forces and the rates of
   the controller states z (n_controllers, after the powers); dy/dt (N_Y) at (t, y). */
GPMEGEN_HIDDEN int gpmegen_stage(const struct gpmegen_model *model, double t, const double *q, const double *qd,
                                 const double *z, const double *p, double *qdd, double *power);
GPMEGEN_HIDDEN int gpmegen_state_rate(const struct gpmegen_model *model, double t, const double *y, const double *p,
                                      double *rate);
/* dop853.c: the first step of an adaptive integrator from (t, y) with rate f0. */
GPMEGEN_HIDDEN int gpmegen_first_step(const struct gpmegen_model *model, double t, const double *y,
                                      const double *f0, double rtol, double atol, double span, const double *p,
                                      double *h, long *evaluations);
/* gpme.c: step k of Gaussian elimination with complete pivoting on the first m rows of D. */
GPMEGEN_HIDDEN int gpmegen_elimination_step(int n_dof, double *D, double *c, int m, int k, double *tiny,
                                            int *column);
/* jacobian.c: LU with partial pivoting and its solve; the GPME solves a Jacobian takes. */
GPMEGEN_HIDDEN int gpmegen_lu_factor(int n, double *a, int *piv);
GPMEGEN_HIDDEN void gpmegen_lu_solve(int n, const double *a, const int *piv, int k, double *b);
GPMEGEN_HIDDEN long gpmegen_jacobian_solves(const struct gpmegen_model *model);
/* controllers.c: p with the controller states z in place; the Jacobian of the whole rate
   (mechanics and controller states) at y = [q, qd, w, z] and the GPME solves it takes. */
GPMEGEN_HIDDEN void gpmegen_with_controllers(const struct gpmegen_model *model, const double *p, const double *z,
                                             double *out);
GPMEGEN_HIDDEN int gpmegen_state_jacobian(const struct gpmegen_model *model, double t, const double *y,
                                          const double *p, double *qdd, double *A_q, double *A_qd, double *A_z,
                                          double *R_q, double *R_qd, double *R_z);
GPMEGEN_HIDDEN long gpmegen_state_jacobian_solves(const struct gpmegen_model *model);

#endif
