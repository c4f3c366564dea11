/* The actuated realization (servo-constraints): the programmed constraints held by inputs u on
   chosen coordinates alone, M qdd = f + S u, instead of by the ideal constraint forces D^T lambda
   (gpmegen.runtime.gpme.actuated is the same solve in NumPy). */

#include "solver_internal.h"

/* qdd (N_DOF) and the inputs u (n_constraints) of the actuated realization on the coordinates
   model->actuators (one per constraint, S their selection, column j the unit vector of
   actuators[j]), from the system of N = N_DOF + n_constraints rows

       [M  -S] [qdd]   [f]
       [D   0] [u  ] = [c],   c the constraint rows' right sides (gpmegen_constraint_rhs),

   solved by dense LU with partial pivoting (gpmegen_lu_factor): N^3 / 3 multiply-adds, against
   the ideal solve's O(N_DOF) recursion; the runs it serves are small (an actuated run has as many
   inputs as constraints). M and f (N_DOF x N_DOF, N_DOF) receive the terms it was solved from,
   *power the power of the inputs, qd . S u. Returns GPMEGEN_OK; GPMEGEN_SINGULAR when the system
   is (D M^-1 S singular: the inputs cannot move the constraints); GPMEGEN_NONFINITE when a term
   is not finite. */
int gpmegen_actuated_solve(const struct gpmegen_model *model, double t, const double *q, const double *qd,
                           const double *p, double *qdd, double *u, double *M, double *f, double *power)
{
    const int N_DOF = model->n_dof, NM = model->n_constraints, N = N_DOF + NM;
    const int *actuators = model->actuators;
    double phi[AT_LEAST_1(NM)] ALIGNED, phi_rate[AT_LEAST_1(NM)] ALIGNED, D[AT_LEAST_1(NM * N_DOF)] ALIGNED;
    double gam[AT_LEAST_1(NM)] ALIGNED, alpha[AT_LEAST_1(NM)] ALIGNED, beta[AT_LEAST_1(NM)] ALIGNED;
    double A[N * N] ALIGNED, x[N] ALIGNED;
    int pivots[N] ALIGNED;
    int status;

    if (actuators == NULL) {
        return GPMEGEN_BAD_ARGUMENTS;
    }
    model->gpme_terms(t, q, qd, p, M, f, phi, phi_rate, D, gam);
    if (NM) {
        model->baumgarte_gains(p, alpha, beta);
        gpmegen_constraint_rhs(model, phi, phi_rate, gam, alpha, beta, x + N_DOF);
    }
    for (int i = 0; i < N_DOF; ++i) {
        for (int j = 0; j < N_DOF; ++j) {
            A[i * N + j] = M[i * N_DOF + j];
        }
        for (int j = N_DOF; j < N; ++j) {
            A[i * N + j] = 0.0;
        }
        x[i] = f[i];
    }
    for (int a = 0; a < NM; ++a) {
        A[actuators[a] * N + N_DOF + a] = -1.0;
        for (int j = 0; j < N_DOF; ++j) {
            A[(N_DOF + a) * N + j] = D[a * N_DOF + j];
        }
        for (int j = N_DOF; j < N; ++j) {
            A[(N_DOF + a) * N + j] = 0.0;
        }
    }
    if (!all_finite(x, N)) {
        return GPMEGEN_NONFINITE;
    }
    if ((status = gpmegen_lu_factor(N, A, pivots)) != GPMEGEN_OK) {
        return status;
    }
    gpmegen_lu_solve(N, A, pivots, 1, x);
    double s = 0.0;
    for (int i = 0; i < N_DOF; ++i) {
        qdd[i] = x[i];
    }
    for (int a = 0; a < NM; ++a) {
        u[a] = x[N_DOF + a];
        s += qd[actuators[a]] * u[a];
    }
    *power = s;
    return GPMEGEN_OK;
}
