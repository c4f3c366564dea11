/* The GPME acceleration Jacobians dqdd/dq, dqdd/dqd that the implicit integrators take: from the
   generated derivatives of the GPME residuals when the model is built with them, else by central
   differences of the model's solve; and the dense LU they and generalized-alpha's Newton matrix
   are solved with. */

#include "solver_internal.h"

/* ---- Dense LU ------------------------------------------------------------------------------ */

/* LU factorization with partial pivoting of the n x n row-major a, in place (unit lower L below
   the diagonal, U on and above); piv[k] is the row swapped with row k at step k. Returns
   GPMEGEN_NONFINITE when an entry is not finite, GPMEGEN_SINGULAR when a pivot is at or below
   n * DBL_EPSILON times the largest entry, else GPMEGEN_OK. */
int gpmegen_lu_factor(int n, double *a, int *piv)
{
    double largest = 0.0;
    for (int i = 0; i < n * n; ++i) {
        if (!isfinite(a[i])) {
            return GPMEGEN_NONFINITE;
        }
        largest = fabs(a[i]) > largest ? fabs(a[i]) : largest;
    }
    const double tiny = (double)n * DBL_EPSILON * largest;
    for (int k = 0; k < n; ++k) {
        int r = k;
        for (int i = k + 1; i < n; ++i) {
            r = fabs(a[i * n + k]) > fabs(a[r * n + k]) ? i : r;
        }
        if (!(fabs(a[r * n + k]) > tiny)) {
            return GPMEGEN_SINGULAR;
        }
        piv[k] = r;
        if (r != k) {
            for (int j = 0; j < n; ++j) {
                const double s = a[k * n + j];
                a[k * n + j] = a[r * n + j];
                a[r * n + j] = s;
            }
        }
        const double inv = 1.0 / a[k * n + k];
        for (int i = k + 1; i < n; ++i) {
            const double l = a[i * n + k] * inv;
            a[i * n + k] = l;
            for (int j = k + 1; j < n; ++j) {
                a[i * n + j] -= l * a[k * n + j];
            }
        }
    }
    return GPMEGEN_OK;
}

/* Solves a x = b for the k columns of b (n x k row-major, overwritten by x), a and piv from
   gpmegen_lu_factor: the body of gpmegen_lu_solve. */
ALWAYS_INLINE static inline void lu_solve_columns(int n, const double *a, const int *piv, int k, double *b)
{
    for (int i = 0; i < n; ++i) {
        if (piv[i] != i) {
            for (int c = 0; c < k; ++c) {
                const double s = b[i * k + c];
                b[i * k + c] = b[piv[i] * k + c];
                b[piv[i] * k + c] = s;
            }
        }
    }
    for (int i = 1; i < n; ++i) {
        for (int r = 0; r < i; ++r) {
            const double l = a[i * n + r];
            for (int c = 0; c < k; ++c) {
                b[i * k + c] -= l * b[r * k + c];
            }
        }
    }
    for (int i = n - 1; i >= 0; --i) {
        for (int r = i + 1; r < n; ++r) {
            const double u = a[i * n + r];
            for (int c = 0; c < k; ++c) {
                b[i * k + c] -= u * b[r * k + c];
            }
        }
        const double inv = 1.0 / a[i * n + i];
        for (int c = 0; c < k; ++c) {
            b[i * k + c] *= inv;
        }
    }
}

/* Solves a x = b for the k columns of b (n x k row-major, overwritten by x), a and piv from
   gpmegen_lu_factor. One column (the Newton iterations' case) has a body of its own, without the
   inner loop over columns; the arithmetic is the same. */
void gpmegen_lu_solve(int n, const double *a, const int *piv, int k, double *b)
{
    if (k == 1) {
        lu_solve_columns(n, a, piv, 1, b);
    } else {
        lu_solve_columns(n, a, piv, k, b);
    }
}

/* ---- Acceleration Jacobians ---------------------------------------------------------------- */

/* The rows of D (NC x N_DOF row-major) that are independent and span its rows, as
   gpmegen.runtime.gpme.independent_rows finds them: the pivots of a QR factorization of D^T with
   column pivoting (here Gram-Schmidt on the rows, twice orthogonalized, the row of largest norm
   left taken first) above GPMEGEN_RANK_TOLERANCE times the first pivot. rows[0..rank-1]
   receive them in increasing order; returns the rank (NC when D has full rank). */
static int independent_rows(int N_DOF, int NC, const double *D, int *rows)
{
    double Q[NC * N_DOF] ALIGNED, basis[NC * N_DOF] ALIGNED;
    int taken[NC] ALIGNED;
    int rank = 0;
    double first = 0.0;
    for (int i = 0; i < NC * N_DOF; ++i) {
        Q[i] = D[i];
    }
    for (int a = 0; a < NC; ++a) {
        taken[a] = 0;
    }
    for (int k = 0; k < NC; ++k) {
        int best = -1;
        double largest = -1.0;
        for (int a = 0; a < NC; ++a) {
            double s = 0.0;
            for (int j = 0; j < N_DOF; ++j) {
                s += Q[a * N_DOF + j] * Q[a * N_DOF + j];
            }
            if (!taken[a] && s > largest) {
                largest = s;
                best = a;
            }
        }
        const double pivot = sqrt(largest);
        if (k == 0) {
            first = pivot;
        }
        if (best < 0 || !(pivot > GPMEGEN_RANK_TOLERANCE * first) || !(first > 0.0)) {
            break;
        }
        taken[best] = 1;
        double *e = basis + rank * N_DOF;
        for (int j = 0; j < N_DOF; ++j) {
            e[j] = Q[best * N_DOF + j] / pivot;
        }
        rank += 1;
        for (int pass = 0; pass < 2; ++pass) {  /* twice: the round-off of once stays below the tolerance */
            for (int a = 0; a < NC; ++a) {
                if (taken[a]) {
                    continue;
                }
                double s = 0.0;
                for (int j = 0; j < N_DOF; ++j) {
                    s += Q[a * N_DOF + j] * e[j];
                }
                for (int j = 0; j < N_DOF; ++j) {
                    Q[a * N_DOF + j] -= s * e[j];
                }
            }
        }
    }
    for (int a = 0, k = 0; a < NC; ++a) {
        if (taken[a]) {
            rows[k++] = a;
        }
    }
    return rank;
}

/* qdd (N_DOF) from the GPME (gpme_recursive) and its Jacobians dqdd_dq, dqdd_dqd (N_DOF x N_DOF
   row-major, [i][j] = d qdd_i / d q_j): differentiating M qdd - f = D^T lam and D qdd = c,
       [M  -D^T] [d qdd]   [dF]      F = f - M a + D^T lam,  C = c - D a  at a = qdd,
       [D    0 ] [d lam] = [dC],     lam fixed (gpme_residual_jacobians),
   with lam = (D D^T)^-1 D (M qdd - f), solved by LU with partial pivoting for the 2 N_DOF
   columns of dq and dqd together, M, f and D from gpme_terms. Where the rows may be redundant
   (redundant_rows) and are at this state (D of rank below its rows), the system takes the
   independent rows (independent_rows) with their multipliers, unique there, the others' zero:
   near the state they hold the same motions as all of them, as the solve keeps them
   (gpmegen.runtime.model.redundant_acceleration_jacobians does the same). Returns the status of
   gpme_recursive, or GPMEGEN_SINGULAR / GPMEGEN_NONFINITE when the system above is singular or
   not finite. */
static int exact_jacobian(const struct gpmegen_model *model, double t, const double *q, const double *qd,
                          const double *p, double *qdd, double *dqdd_dq, double *dqdd_dqd)
{
    const int N_DOF = model->n_dof, NC = model->n_constraints, NR = 2 * N_DOF;
    double M[N_DOF * N_DOF] ALIGNED, f[N_DOF] ALIGNED, power;
    double K[(N_DOF + NC) * (N_DOF + NC)] ALIGNED, rhs[(N_DOF + NC) * NR] ALIGNED;
    double F_q[N_DOF * N_DOF] ALIGNED, F_qd[N_DOF * N_DOF] ALIGNED;
    double C_q[AT_LEAST_1(NC * N_DOF)] ALIGNED, C_qd[AT_LEAST_1(NC * N_DOF)] ALIGNED;
    double lam[AT_LEAST_1(NC)] ALIGNED;
    int rows[AT_LEAST_1(NC)] ALIGNED;  /* the rows the system takes: all, or the independent ones */
    int piv[N_DOF + NC] ALIGNED;
    int status, NK = N_DOF, NI = 0;

    lam[0] = 0.0;
    if ((status = model->gpme_recursive(t, q, qd, p, qdd, &power)) != GPMEGEN_OK) {
        return status;
    }
    if (NC > 0) {
        double phi[NC] ALIGNED, phi_rate[NC] ALIGNED, gam[NC] ALIGNED;
        double D[NC * N_DOF] ALIGNED, DDt[NC * NC] ALIGNED, r[N_DOF] ALIGNED, mu[NC] ALIGNED;
        int piv_c[NC] ALIGNED;
        model->gpme_terms(t, q, qd, p, M, f, phi, phi_rate, D, gam);
        if (!all_finite(D, NC * N_DOF)) {
            return GPMEGEN_NONFINITE;
        }
        if (model->redundant_rows) {
            NI = independent_rows(N_DOF, NC, D, rows);
        }
        else {
            for (NI = 0; NI < NC; ++NI) {
                rows[NI] = NI;
            }
        }
        if (NI == 0) {
            return GPMEGEN_SINGULAR;
        }
        NK = N_DOF + NI;
        for (int i = 0; i < N_DOF; ++i) {  /* M qdd - f */
            double s = -f[i];
            for (int j = 0; j < N_DOF; ++j) {
                s += M[i * N_DOF + j] * qdd[j];
            }
            r[i] = s;
        }
        for (int a = 0; a < NI; ++a) {
            const double *Da = D + rows[a] * N_DOF;
            double s = 0.0;
            for (int j = 0; j < N_DOF; ++j) {
                s += Da[j] * r[j];
            }
            mu[a] = s;
            for (int b = 0; b < NI; ++b) {
                const double *Db = D + rows[b] * N_DOF;
                double v = 0.0;
                for (int j = 0; j < N_DOF; ++j) {
                    v += Da[j] * Db[j];
                }
                DDt[a * NI + b] = v;
            }
        }
        if ((status = gpmegen_lu_factor(NI, DDt, piv_c)) != GPMEGEN_OK) {
            return status;
        }
        gpmegen_lu_solve(NI, DDt, piv_c, 1, mu);
        for (int a = 0; a < NC; ++a) {
            lam[a] = 0.0;
        }
        for (int a = 0; a < NI; ++a) {
            lam[rows[a]] = mu[a];
            for (int j = 0; j < N_DOF; ++j) {
                K[j * NK + N_DOF + a] = -D[rows[a] * N_DOF + j];
                K[(N_DOF + a) * NK + j] = D[rows[a] * N_DOF + j];
            }
            for (int b = 0; b < NI; ++b) {
                K[(N_DOF + a) * NK + N_DOF + b] = 0.0;
            }
        }
    }
    else {
        double none[1] ALIGNED;
        model->gpme_terms(t, q, qd, p, M, f, none, none, none, none);
    }
    model->gpme_residual_jacobians(t, q, qd, qdd, lam, p, F_q, F_qd, C_q, C_qd);
    for (int i = 0; i < N_DOF; ++i) {
        for (int j = 0; j < N_DOF; ++j) {
            K[i * NK + j] = M[i * N_DOF + j];
            rhs[i * NR + j] = F_q[i * N_DOF + j];
            rhs[i * NR + N_DOF + j] = F_qd[i * N_DOF + j];
        }
    }
    for (int a = 0; a < NI; ++a) {
        for (int j = 0; j < N_DOF; ++j) {
            rhs[(N_DOF + a) * NR + j] = C_q[rows[a] * N_DOF + j];
            rhs[(N_DOF + a) * NR + N_DOF + j] = C_qd[rows[a] * N_DOF + j];
        }
    }
    if ((status = gpmegen_lu_factor(NK, K, piv)) != GPMEGEN_OK) {
        return status;
    }
    gpmegen_lu_solve(NK, K, piv, NR, rhs);
    for (int i = 0; i < N_DOF; ++i) {
        for (int j = 0; j < N_DOF; ++j) {
            dqdd_dq[i * N_DOF + j] = rhs[i * NR + j];
            dqdd_dqd[i * N_DOF + j] = rhs[i * NR + N_DOF + j];
        }
    }
    return GPMEGEN_OK;
}

/* qdd (N_DOF) = the model's recursive accelerations at (t, q, qd), and their Jacobians dqdd_dq
   and dqdd_dqd by central differences of the same solve, with steps cbrt(DBL_EPSILON)
   max(1, |x_j|) (about 1e-10 relative, 4 N_DOF + 1 solves), for a model built without its
   Jacobians (gpmegen build --jacobians). An implicit integrator refreshes its Jacobian rarely, so
   these cost little there; the generated ones are exact, and cheaper to build without. */
static int differenced_jacobian(const struct gpmegen_model *model, double t, const double *q, const double *qd,
                                const double *p, double *qdd, double *dqdd_dq, double *dqdd_dqd)
{
    const int N_DOF = model->n_dof;
    double x[2 * N_DOF] ALIGNED, up[N_DOF] ALIGNED, down[N_DOF] ALIGNED;
    double power;
    const double relative = cbrt(DBL_EPSILON);
    int status;
    if ((status = model->gpme_recursive(t, q, qd, p, qdd, &power)) != GPMEGEN_OK) {
        return status;
    }
    for (int i = 0; i < N_DOF; ++i) {
        x[i] = q[i];
        x[N_DOF + i] = qd[i];
    }
    for (int j = 0; j < 2 * N_DOF; ++j) {
        const double h = relative * fmax(1.0, fabs(x[j])), saved = x[j];
        x[j] = saved + h;
        if ((status = model->gpme_recursive(t, x, x + N_DOF, p, up, &power)) != GPMEGEN_OK) {
            return status;
        }
        x[j] = saved - h;
        if ((status = model->gpme_recursive(t, x, x + N_DOF, p, down, &power)) != GPMEGEN_OK) {
            return status;
        }
        x[j] = saved;
        double *column = j < N_DOF ? dqdd_dq + j : dqdd_dqd + (j - N_DOF);
        for (int i = 0; i < N_DOF; ++i) {
            column[i * N_DOF] = (up[i] - down[i]) / (2.0 * h);
        }
    }
    return GPMEGEN_OK;
}

/* GPME solves one gpmegen_gpme_jacobian takes (as an integrator counts them). */
long gpmegen_jacobian_solves(const struct gpmegen_model *model)
{
    return model->gpme_residual_jacobians != NULL ? 1 : 4 * (long)model->n_dof + 1;
}

/* qdd (N_DOF) and its Jacobians dqdd_dq, dqdd_dqd (N_DOF x N_DOF row-major, [i * N_DOF + j] =
   d qdd_i / d q_j): exact when the model has its generated residual Jacobians, else by central
   differences. Returns the status of the model's solve, or GPMEGEN_SINGULAR / GPMEGEN_NONFINITE
   when the exact Jacobians' system is singular or not finite. */
int gpmegen_gpme_jacobian(const struct gpmegen_model *model, double t, const double *q, const double *qd,
                          const double *p, double *qdd, double *dqdd_dq, double *dqdd_dqd)
{
    return model->gpme_residual_jacobians != NULL ? exact_jacobian(model, t, q, qd, p, qdd, dqdd_dq, dqdd_dqd)
                                                  : differenced_jacobian(model, t, q, qd, p, qdd, dqdd_dq, dqdd_dqd);
}
