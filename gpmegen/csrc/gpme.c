/* The GPME (paper eqs. 12-16) by the dense solve (its LDL^T and the constraint rows' right
   sides are the kernels of gpmegen_solver.h, which the model's recursion shares). */

#include "solver_internal.h"

/* |x| as the integer of its bits with the sign cleared (IEEE 754 doubles): these integers order
   like the magnitudes, with infinity and NaN above every finite value. */
static long long magnitude_bits(double x)
{
    const union { double d; long long i; } v = { x };
    return v.i & 0x7fffffffffffffffLL;
}

/* Index of the entry of largest magnitude in x[0..n-1] (the first of equal ones), or -1 when an
   entry is not finite. The maximum is taken over magnitude_bits(), which the compiler vectorizes:
   a running floating-point maximum is a chain of dependent comparisons, and made the step 3-5%
   slower at n_rfe = 5. */
static int largest_entry(const double *x, int n)
{
    long long largest = 0;
    for (int i = 0; i < n; ++i) {
        const long long m = magnitude_bits(x[i]);
        largest = m > largest ? m : largest;
    }
    if (largest >= 0x7ff0000000000000LL) {  /* the bits of infinity */
        return -1;
    }
    int i = 0;
    while (magnitude_bits(x[i]) != largest) {
        ++i;
    }
    return i;
}

/* Step k of Gaussian elimination with complete pivoting on the first m rows of D (row-major,
   N_DOF columns) and their right side c: the entry of largest magnitude in rows k..m-1 is the
   pivot, its row swapped into row k and taken out of the rows below (exact zeros left in its
   column). *column: the pivot's column; *tiny: set at k = 0 to N_DOF * DBL_EPSILON times that
   entry. Returns GPMEGEN_NONFINITE when an entry of D is not finite, GPMEGEN_SINGULAR when the
   pivot is at or below *tiny (D has lost rank), else GPMEGEN_OK. */
int gpmegen_elimination_step(int N_DOF, double *D, double *c, int m, int k, double *tiny, int *column)
{
    const int at = largest_entry(D + k * N_DOF, (m - k) * N_DOF);
    if (at < 0) {
        return GPMEGEN_NONFINITE;
    }
    const int pivot_row = k + at / N_DOF, pivot = at % N_DOF;
    const double largest = fabs(D[k * N_DOF + at]);
    if (k == 0) {
        *tiny = (double)N_DOF * DBL_EPSILON * largest;
    }
    if (!(largest > *tiny)) {
        return GPMEGEN_SINGULAR;
    }
    *column = pivot;
    if (pivot_row != k) {
        for (int j = 0; j < N_DOF; ++j) {
            const double s = D[k * N_DOF + j];
            D[k * N_DOF + j] = D[pivot_row * N_DOF + j];
            D[pivot_row * N_DOF + j] = s;
        }
        const double s = c[k];
        c[k] = c[pivot_row];
        c[pivot_row] = s;
    }
    const double *row = D + k * N_DOF;
    const double inv = 1.0 / row[pivot];
    for (int a = k + 1; a < m; ++a) {
        const double factor = D[a * N_DOF + pivot] * inv;
        for (int j = 0; j < N_DOF; ++j) {
            D[a * N_DOF + j] -= factor * row[j];
        }
        D[a * N_DOF + pivot] = 0.0;
        c[a] -= factor * c[k];
    }
    return GPMEGEN_OK;
}

/* The rank of the constraint rows D qdd = c (D: NC x N_DOF row-major, c: NC) by Gaussian
   elimination with complete pivoting (gpmegen_elimination_step); dependent[a] is the coordinate
   of the a-th pivot. A model whose rows cannot be redundant (redundant_rows 0) stops as that
   function says: a pivot at or below N_DOF * DBL_EPSILON times D's largest entry is
   GPMEGEN_SINGULAR. A model whose rows may be (redundant_rows 1) stops its elimination there
   with the rank found, or at a pivot at or below GPMEGEN_RANK_TOLERANCE times D's largest entry:
   the rows left are combinations of the pivoted ones up to round-off. The accelerations come from the
   pivoted rows alone: they are unique when the redundant rows are consistent (their right sides,
   once eliminated, vanish), which the start checks on Phi (a loop that cannot close is refused
   there) and a run watches between its calls (gpmegen.runtime.redundancy: a rank that changes,
   rows left out that drift from the kept ones, each said once; the violation limit stops it).
   D and c are overwritten. *rank: the number of pivots (NC when D has full rank: then nothing
   differs from the elimination of full-rank rows). Returns GPMEGEN_NONFINITE when an entry of D is
   not finite, GPMEGEN_SINGULAR when no row has a pivot (D vanishes), else GPMEGEN_OK. */
static int constraint_rank(int N_DOF, int NC, int redundant_rows, double *D, double *c, int *dependent, int *rank)
{
    double tiny = 0.0, largest = 0.0;
    for (int k = 0; k < NC; ++k) {
        const int status = gpmegen_elimination_step(N_DOF, D, c, NC, k, &tiny, &dependent[k]);
        if (k == 0) {
            largest = tiny / ((double)N_DOF * DBL_EPSILON);
        }
        if (redundant_rows && k > 0 && (status == GPMEGEN_SINGULAR
                                        || (status == GPMEGEN_OK && fabs(D[k * N_DOF + dependent[k]])
                                                                    <= GPMEGEN_RANK_TOLERANCE * largest))) {
            *rank = k;
            return GPMEGEN_OK;
        }
        if (status != GPMEGEN_OK) {
            return status;
        }
    }
    *rank = NC;
    return GPMEGEN_OK;
}

/* The independent rows of D qdd = c left by constraint_rank() (the first NR rows, pivots
   dependent[0..NR-1]) solved for the dependent accelerations, qdd_dc = x_c - X qdd_ic:
   independent holds the coordinates that are not pivots in increasing order,
   X[a * NX + j] (NX = N_DOF - NR + 1) = (D_dc^-1 D_ic)_aj and X[a * NX + NX - 1] = (D_dc^-1 c)_a.
   Each pivot is the largest entry of the rows not pivoted yet (the elimination leaves exact zeros
   in the columns already chosen), so |X_aj| <= 2^(NR - 1 - a): the basis B = [I; -X] of the
   allowed motions stays well conditioned. */
static void constraint_basis(int N_DOF, int NR, const double *D, const double *c, const int *dependent,
                             int *independent, double *X)
{
    const int NI = N_DOF - NR, NX = NI + 1;
    int is_dependent[N_DOF] ALIGNED;
    for (int j = 0; j < N_DOF; ++j) {
        is_dependent[j] = 0;
    }
    for (int a = 0; a < NR; ++a) {
        is_dependent[dependent[a]] = 1;
    }
    for (int j = 0, i = 0; j < N_DOF; ++j) {
        if (!is_dependent[j]) {
            independent[i++] = j;
        }
    }
    /* back substitution through the triangle the pivots left in the dependent columns */
    for (int a = 0; a < NR; ++a) {
        for (int j = 0; j < NI; ++j) {
            X[a * NX + j] = D[a * N_DOF + independent[j]];
        }
        X[a * NX + NI] = c[a];
    }
    for (int a = NR - 1; a >= 0; --a) {
        const double *row = D + a * N_DOF;
        for (int b = a + 1; b < NR; ++b) {
            const double u = row[dependent[b]];
            for (int j = 0; j < NX; ++j) {
                X[a * NX + j] -= u * X[b * NX + j];
            }
        }
        const double inv = 1.0 / row[dependent[a]];
        for (int j = 0; j < NX; ++j) {
            X[a * NX + j] *= inv;
        }
    }
}

/* qdd (N_DOF) = M^-1 f: the model has no programmed constraints and *power, that of the
   constraint forces, is zero. Returns GPMEGEN_OK; GPMEGEN_SINGULAR when M is not positive
   definite; GPMEGEN_NONFINITE when M is not finite. */
static int unconstrained_solve(const struct gpmegen_model *model, double t, const double *q, const double *qd,
                               const double *p, double *qdd, double *M, double *f, double *power)
{
    const int N_DOF = model->n_dof;
    double L[N_DOF * N_DOF] ALIGNED, inv_d[N_DOF] ALIGNED;
    double none[1] ALIGNED;
    int status;
    model->gpme_terms(t, q, qd, p, M, f, none, none, none, none);
    for (int i = 0; i < N_DOF * N_DOF; ++i) {
        L[i] = M[i];
    }
    if ((status = gpmegen_ldlt(N_DOF, L, inv_d)) != GPMEGEN_OK) {
        return status;
    }
    for (int i = 0; i < N_DOF; ++i) {
        qdd[i] = f[i];
    }
    gpmegen_ldlt_solve(N_DOF, L, inv_d, qdd);
    *power = 0.0;
    return GPMEGEN_OK;
}

/* The GPME with Baumgarte terms (paper eqs. 12-16):
       B^T (M qdd - f) = 0                             one row per independent coordinate,
       D qdd = c,  c = -gamma - 2 alpha phi_rate - beta^2 phi   (position constraints)
                   c = -gamma - alpha phi                       (first-order constraints),
                   c = -gamma                                   (second-order constraints),
   with X = D_dc^-1 D_ic and B = [I; -X] arranged by coordinate index. Every basis B of the
   motions the constraints allow gives the same qdd, so the dependent coordinates are chosen here,
   at each call, as the pivots of constraint_basis() (|X| <= 2^(m-1) for m constraints), not taken
   from the model's partition: where the partition's D_dc is nearly singular (elastic angles near
   1 rad at n_rfe = 5 and 10) its X is large and cond(B^T M B) grows as |X|^2 cond(M); the
   factorization below then lost 1e-6 of qdd's relative accuracy at cond(B^T M B) ~ 1e11, more
   beyond, and failed as singular while D was regular.
   Solved in the independent accelerations z = qdd_ic: every qdd meeting the constraint rows is
   qdd = B z + qdd_p with qdd_p,dc = x_c = D_dc^-1 c and qdd_p,ic = 0, so the first rows become
   the reduced system R z = r, R = B^T M B (symmetric positive definite, LDL^T) and
   r = B^T (f - M qdd_p). Written out with W = M_dc,ic - M_dc,dc X and w = f_dc - M_dc,dc x_c:
       R = M_ic,ic - M_ic,dc X - X^T W,    r = f_ic - M_ic,dc x_c - X^T w,
   which forms no M B and only the upper triangle of R.
   *power receives the power of the constraint forces, qd . (M qdd - f) = (M^T qd) . qdd - qd . f:
   M^T qd does not wait for the solve, so it runs beside the factorization.
   A model without constraints: qdd = M^-1 f and *power = 0.
   Redundant rows (D of rank below its number of rows, constraint_rank()): the rows pivoted before
   the rank is reached are the constraint rows here, the others are left out (the accelerations
   are those of every consistent set of rows; the multipliers are not unique, and are computed
   apart as the minimum-norm ones).
   Returns GPMEGEN_OK; GPMEGEN_SINGULAR when D vanishes or B^T M B is singular;
   GPMEGEN_NONFINITE when a term is not finite. */
int gpmegen_gpme_solve(const struct gpmegen_model *model, double t, const double *q, const double *qd,
                       const double *p, double *qdd, double *M, double *f, double *power)
{
    if (model->n_constraints == 0) {
        return unconstrained_solve(model, t, q, qd, p, qdd, M, f, power);
    }
    const int N_DOF = model->n_dof, NM = model->n_constraints;
    double phi[NM] ALIGNED, phi_rate[NM] ALIGNED, D[NM * N_DOF] ALIGNED, gam[NM] ALIGNED;
    double alpha[NM] ALIGNED, beta[NM] ALIGNED, c[NM] ALIGNED;
    int dependent[NM] ALIGNED;
    double m_qd[N_DOF] ALIGNED, qd_f = 0.0;
    int status, NC;

    model->gpme_terms(t, q, qd, p, M, f, phi, phi_rate, D, gam);
    model->baumgarte_gains(p, alpha, beta);
    /* M^T qd, row by row of M so that the inner loop runs along contiguous memory */
    for (int i = 0; i < N_DOF; ++i) {
        m_qd[i] = 0.0;
        qd_f += qd[i] * f[i];
    }
    for (int k = 0; k < N_DOF; ++k) {
        const double v = qd[k];
        const double *row = M + k * N_DOF;
        for (int i = 0; i < N_DOF; ++i) {
            m_qd[i] += row[i] * v;
        }
    }
    gpmegen_constraint_rhs(model, phi, phi_rate, gam, alpha, beta, c);
    /* NC: the rank of D, the number of rows kept (all NM of them unless some are redundant) */
    if ((status = constraint_rank(N_DOF, NM, model->redundant_rows, D, c, dependent, &NC)) != GPMEGEN_OK) {
        return status;
    }
    const int NI = N_DOF - NC, NX = NI + 1;
    int independent[AT_LEAST_1(NI)] ALIGNED;
    double X[NC * NX] ALIGNED;  /* [X | x_c] = D_dc^-1 [D_ic | c] */
    double W[NC * NX] ALIGNED;  /* [W | w] */
    double R[AT_LEAST_1(NI * NI)] ALIGNED;
    double inv_d[AT_LEAST_1(NI)] ALIGNED, z[AT_LEAST_1(NI)] ALIGNED;
    double m_id[NC] ALIGNED;
    constraint_basis(N_DOF, NC, D, c, dependent, independent, X);
    for (int a = 0; a < NC; ++a) {
        const double *row = M + dependent[a] * N_DOF;
        for (int j = 0; j < NI; ++j) {
            double w = row[independent[j]];
            for (int b = 0; b < NC; ++b) {
                w -= row[dependent[b]] * X[b * NX + j];
            }
            W[a * NX + j] = w;
        }
        double w = f[dependent[a]];
        for (int b = 0; b < NC; ++b) {
            w -= row[dependent[b]] * X[b * NX + NI];
        }
        W[a * NX + NI] = w;
    }
    for (int i = 0; i < NI; ++i) {
        const double *row = M + independent[i] * N_DOF;
        for (int a = 0; a < NC; ++a) {
            m_id[a] = row[dependent[a]];
        }
        double s = f[independent[i]];
        for (int a = 0; a < NC; ++a) {
            s -= m_id[a] * X[a * NX + NI];
        }
        for (int a = 0; a < NC; ++a) {
            s -= X[a * NX + i] * W[a * NX + NI];
        }
        z[i] = s;
        for (int j = i; j < NI; ++j) {
            double v = row[independent[j]];
            for (int a = 0; a < NC; ++a) {
                v -= m_id[a] * X[a * NX + j];
            }
            for (int a = 0; a < NC; ++a) {
                v -= X[a * NX + i] * W[a * NX + j];
            }
            R[i * NI + j] = v;
        }
    }
    if ((status = gpmegen_ldlt(NI, R, inv_d)) != GPMEGEN_OK) {
        return status;
    }
    gpmegen_ldlt_solve(NI, R, inv_d, z);
    for (int j = 0; j < NI; ++j) {
        qdd[independent[j]] = z[j];
    }
    for (int a = 0; a < NC; ++a) {
        double s = X[a * NX + NI];
        for (int j = 0; j < NI; ++j) {
            s -= X[a * NX + j] * z[j];
        }
        qdd[dependent[a]] = s;
    }
    double s = -qd_f;
    for (int i = 0; i < N_DOF; ++i) {
        s += m_qd[i] * qdd[i];
    }
    *power = s;
    return GPMEGEN_OK;
}
