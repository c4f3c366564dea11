/* Generalized-alpha (Chung and Hulbert 1993) for qdd = a(t, q, qd), with the post-stabilization
   of its steps' ends. */

#include "solver_internal.h"

/* The parameters of the generalized-alpha method with spectral radius rho_inf at h omega -> inf
   (Chung and Hulbert; Arnold and Bruls 2007 for qdd given): second order, unconditionally stable
   for linear problems, the high frequencies damped to rho_inf, the low ones barely. */
struct genalpha_parameters {
    double alpha_m, alpha_f, gamma, beta;
};

static struct genalpha_parameters genalpha_parameters(double rho_inf)
{
    struct genalpha_parameters c;
    c.alpha_m = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0);
    c.alpha_f = rho_inf / (rho_inf + 1.0);
    c.gamma = 0.5 + c.alpha_f - c.alpha_m;
    c.beta = 0.25 * (c.gamma + 0.5) * (c.gamma + 0.5);
    return c;
}

/* Newton's iteration matrix at the state y = [q, qd, w, z] at t, for the unknowns qdd_{n+1}
   (N_DOF) and the controller states z_{n+1} (N_Z; none in most models) of a step h, factored into
   S (N_R x N_R, N_R = N_DOF + N_Z) and pivot:
       S = [[I - dq A_q - dqd A_qd, -A_z], [-(h / 2) (dq R_q + dqd R_qd), I - (h / 2) R_z]]
   (the A of qdd, the R of z's rates, of gpmegen_state_jacobian), with dq = beta h^2 c and
   dqd = gamma h c the changes of q and qd per change of qdd, c = (1 - alpha_f) / (1 - alpha_m)
   that of a, and h / 2 the trapezoidal rule's weight of z's rate at the step's end. Adds the
   solves, the Jacobian and the factorization to counts. */
static int genalpha_matrix(const struct gpmegen_model *model, double t, const double *y, double h,
                           struct genalpha_parameters c, const double *p, double *S, int *pivot, long *counts)
{
    const int N_DOF = model->n_dof, N_Z = model->n_controllers, N_R = N_DOF + N_Z;
    /* A_q in S itself where S is N_DOF x N_DOF (no controller states): each entry of S is made
       from the same entry of A_q alone, and the stack keeps one matrix less */
    double qdd[N_DOF] ALIGNED, A_q_room[N_Z ? N_DOF * N_DOF : 1] ALIGNED, A_qd[N_DOF * N_DOF] ALIGNED;
    double *const A_q = N_Z ? A_q_room : S;
    double A_z[AT_LEAST_1(N_DOF * N_Z)] ALIGNED, R_q[AT_LEAST_1(N_Z * N_DOF)] ALIGNED;
    double R_qd[AT_LEAST_1(N_Z * N_DOF)] ALIGNED, R_z[AT_LEAST_1(N_Z * N_Z)] ALIGNED;
    const double da = (1.0 - c.alpha_f) / (1.0 - c.alpha_m), dq = c.beta * h * h * da, dqd = c.gamma * h * da;
    int status;
    counts[2] += 4 * N_DOF + 1 + 2 * N_Z;
    ++counts[3];
    if ((status = gpmegen_state_jacobian(model, t, y, p, qdd, A_q, A_qd, A_z, R_q, R_qd, R_z)) != GPMEGEN_OK) {
        return status;
    }
    for (int i = 0; i < N_DOF; ++i) {
        for (int j = 0; j < N_DOF; ++j) {
            S[i * N_R + j] = -dq * A_q[i * N_DOF + j] - dqd * A_qd[i * N_DOF + j];
        }
        S[i * N_R + i] += 1.0;
        for (int j = 0; j < N_Z; ++j) {
            S[i * N_R + N_DOF + j] = -A_z[i * N_Z + j];
        }
    }
    for (int k = 0; k < N_Z; ++k) {
        for (int j = 0; j < N_DOF; ++j) {
            S[(N_DOF + k) * N_R + j] = -0.5 * h * (dq * R_q[k * N_DOF + j] + dqd * R_qd[k * N_DOF + j]);
        }
        for (int j = 0; j < N_Z; ++j) {
            S[(N_DOF + k) * N_R + N_DOF + j] = (k == j) - 0.5 * h * R_z[k * N_Z + j];
        }
    }
    ++counts[4];
    return gpmegen_lu_factor(N_R, S, pivot);
}

/* The state y = [q, qd, w, z] at t + x h within a step from y0 (rates: qd0, qdd0, powers P0) to y1
   (qd1, qdd1, P1): each part the cubic Hermite interpolant of its values and rates at the ends,
   exact for cubics, so its error O(h^4) stays below the method's O(h^2). */
static void hermite_state(int N_Y, double x, double h, const double *y0, const double *r0, const double *y1,
                          const double *r1, double *out)
{
    const double h00 = (1.0 + 2.0 * x) * (1.0 - x) * (1.0 - x), h10 = x * (1.0 - x) * (1.0 - x);
    const double h01 = x * x * (3.0 - 2.0 * x), h11 = x * x * (x - 1.0);
    for (int i = 0; i < N_Y; ++i) {
        out[i] = h00 * y0[i] + h * h10 * r0[i] + h01 * y1[i] + h * h11 * r1[i];
    }
}

/* ---- Post-stabilization: a step's end put back onto the constraints ---------------------------- */

/* The projection's Newton iterations on Phi stop when max |Phi| <= PROJECTION_TOLERANCE (m, m^2
   or rad: the units of the reference arm's constraints, whose values are O(1); their round-off
   is 1e-15) or when the correction is at the round-off of q; the step fails when they have not
   after PROJECTION_ITERATIONS (one or two suffice from a step's O(h^3) violation). */
static const double PROJECTION_TOLERANCE = 1e-12;
enum { PROJECTION_ITERATIONS = 8 };

/* The constraints held at position level (velocity 0: the order-0 rows, residual Phi) or at
   velocity level (velocity 1: orders 0 and 1, residuals Phi_dot = D qd + Phi_t and Psi, both
   linear in qd with the rows D) at (t, q, qd): their rows of D into D (m x N_DOF) and their
   residuals into r (m). Second-order constraints bind the accelerations only: never here.
   Returns m. */
static int held_rows(const struct gpmegen_model *model, double t, const double *q, const double *qd,
                     const double *p, int velocity, double *D, double *r)
{
    const int N_DOF = model->n_dof, N_CONSTRAINTS = model->n_constraints;
    const int *CONSTRAINT_ORDERS = model->constraint_orders;
    double phi[N_CONSTRAINTS] ALIGNED, phi_rate[N_CONSTRAINTS] ALIGNED, gam[N_CONSTRAINTS] ALIGNED;
    double all_rows[N_CONSTRAINTS * N_DOF] ALIGNED;
    int m = 0;
    model->constraint_terms(t, q, qd, p, phi, phi_rate, all_rows, gam);
    for (int a = 0; a < N_CONSTRAINTS; ++a) {
        if (CONSTRAINT_ORDERS[a] == 0 || (velocity && CONSTRAINT_ORDERS[a] == 1)) {
            for (int j = 0; j < N_DOF; ++j) {
                D[m * N_DOF + j] = all_rows[a * N_DOF + j];
            }
            r[m++] = velocity && CONSTRAINT_ORDERS[a] == 0 ? phi_rate[a] : phi[a];
        }
    }
    return m;
}

/* dx (N_DOF) with D dx = -r (D: m x N_DOF row-major, r: m; both overwritten) that moves only m
   coordinates: the pivots of gpmegen_elimination_step(), as the GPME's dense solve chooses its
   dependent coordinates (the largest entry of the rows left), so the correction stays
   well conditioned wherever the model's fixed partition would not. For a model whose rows may be
   redundant (redundant_rows), rows past the rank (the pivot of row k at or below the
   elimination's threshold, k > 0: D has rank k) are left out, the
   correction made from the independent ones. Returns the status of gpmegen_elimination_step(). */
static int pivot_correction(int N_DOF, int N_CONSTRAINTS, int redundant_rows, int m, double *D, double *r,
                            double *dx)
{
    int column[N_CONSTRAINTS] ALIGNED;
    double tiny = 0.0;
    for (int k = 0; k < m; ++k) {
        const int status = gpmegen_elimination_step(N_DOF, D, r, m, k, &tiny, &column[k]);
        if (redundant_rows && status == GPMEGEN_SINGULAR && k > 0) {  /* rows k.. are redundant: the pivoted ones move q */
            m = k;
            break;
        }
        if (status != GPMEGEN_OK) {
            return status;
        }
    }
    for (int j = 0; j < N_DOF; ++j) {
        dx[j] = 0.0;
    }
    for (int k = m - 1; k >= 0; --k) {
        double s = -r[k];
        for (int b = k + 1; b < m; ++b) {
            s -= D[k * N_DOF + column[b]] * dx[column[b]];
        }
        dx[column[k]] = s / D[k * N_DOF + column[k]];
    }
    return GPMEGEN_OK;
}

/* Puts the state y = [q, qd, ...] at t back onto the constraints (Bauchau and Laulusa 2008,
   post-stabilization): Newton on Phi(q, t) = 0 of the position constraints moving the pivot
   coordinates of pivot_correction() (a fresh D each iteration), then qd corrected in the same
   way so that D qd + Phi_t = 0 and, for the first-order constraints, Psi = 0 (linear in qd: one
   solve). *evaluations counts the constraint evaluations. Returns GPMEGEN_OK, the status of
   pivot_correction() or GPMEGEN_NO_CONVERGENCE. */
static int project_state(const struct gpmegen_model *model, double t, double *y, const double *p, long *evaluations)
{
    const int N_DOF = model->n_dof, N_CONSTRAINTS = model->n_constraints;
    const int *CONSTRAINT_ORDERS = model->constraint_orders;
    double D[N_CONSTRAINTS * N_DOF] ALIGNED, r[N_CONSTRAINTS] ALIGNED, dx[N_DOF] ALIGNED;
    double *q = y, *qd = y + N_DOF;
    int status, m, held = 0;
    for (int a = 0; a < N_CONSTRAINTS; ++a) {
        held |= CONSTRAINT_ORDERS[a] < 2;
    }
    if (!held) {  /* second-order constraints only: nothing to evaluate */
        return GPMEGEN_OK;
    }
    for (int iteration = 0;; ++iteration) {
        ++*evaluations;
        if ((m = held_rows(model, t, q, qd, p, 0, D, r)) == 0) {
            break;
        }
        double worst = 0.0;
        for (int a = 0; a < m; ++a) {
            if (!isfinite(r[a])) {
                return GPMEGEN_NONFINITE;
            }
            worst = fmax(worst, fabs(r[a]));
        }
        if (worst <= PROJECTION_TOLERANCE) {
            break;
        }
        if (iteration == PROJECTION_ITERATIONS) {
            return GPMEGEN_NO_CONVERGENCE;
        }
        if ((status = pivot_correction(N_DOF, N_CONSTRAINTS, model->redundant_rows, m, D, r, dx)) != GPMEGEN_OK) {
            return status;
        }
        int moved = 0;
        for (int j = 0; j < N_DOF; ++j) {
            moved |= fabs(dx[j]) > 2.0 * DBL_EPSILON * fmax(1.0, fabs(q[j]));
            q[j] += dx[j];
        }
        if (!moved) {  /* at the round-off of q: nothing more to gain */
            break;
        }
    }
    ++*evaluations;
    if ((m = held_rows(model, t, q, qd, p, 1, D, r)) == 0) {
        return GPMEGEN_OK;
    }
    if ((status = pivot_correction(N_DOF, N_CONSTRAINTS, model->redundant_rows, m, D, r, dx)) != GPMEGEN_OK) {
        return status;
    }
    for (int j = 0; j < N_DOF; ++j) {
        qd[j] += dx[j];
    }
    return GPMEGEN_OK;
}

/* Newton's iterations stop when the largest increment of qdd and of the controller states z, or
   from the second iteration on the error that increment leaves, estimated from the iteration's
   contraction theta (the ratio of two increments) as theta / (1 - theta) times it (Hairer and
   Wanner, Radau5), is at most NEWTON_TOLERANCE max(1, |qdd|, |z|); the matrix is
   refreshed when they have not converged after NEWTON_ITERATIONS or converge slower than
   NEWTON_RATE a step, and the step fails when they do not converge with a fresh one. The
   tolerance stays above the round-off of the solve itself: qdd of the reference arm at
   n_rfe = 20 moves by 1e-10 of max |qdd| when q moves by 1e-15, and 1e-10 failed there. */
static const double NEWTON_TOLERANCE = 1e-8, NEWTON_RATE = 0.5;
enum { NEWTON_ITERATIONS = 6 };

/* Generalized-alpha over steps k_from + 1 .. k_to of the grid of gpmegen_rk4 (n_steps steps of dt from
   t0, the last ending at t_end), with numerical damping rho_inf (0..1), from y_io = [q, qd, w, z]
   (N_Y; z the controller states) and a_io (2 N_DOF): the method's acceleration-like variable (NaN
   at the start of a run: it starts as qdd there) and qdd at the start of the step before (NaN
   where there is none), both replaced by their values at the end of step k_to. Newton's iteration
   starts from qdd extrapolated linearly from the last two steps (from qdd_n at a run's first step):
   its error O(h^2) rather than O(h) takes an iteration less a step where the motion is smooth.
   Each step solves
   qdd_{n+1} = a(t_{n+1}, q_{n+1}, qd_{n+1}) with
       q_{n+1}  = q_n + h qd_n + h^2 ((1/2 - beta) a_n + beta a_{n+1}),
       qd_{n+1} = qd_n + h ((1 - gamma) a_n + gamma a_{n+1}),
       (1 - alpha_m) a_{n+1} + alpha_m a_n = (1 - alpha_f) qdd_{n+1} + alpha_f qdd_n
   and the controller states by the trapezoidal rule (second order as the scheme is on the motion,
   and A-stable), z_{n+1} = z_n + (h / 2) (r_n + r(t_{n+1}, q_{n+1}, qd_{n+1}, z_{n+1})),
   solved with qdd_{n+1} in the same modified Newton iteration (S of genalpha_matrix, N_R x N_R,
   kept across steps and chunks while it converges, *have_matrix says whether S and pivot (N_R)
   hold one); w by the trapezoidal rule on the powers.
   Saves y at the n_save increasing instants t_save within (t_{k_from}, t_{k_to}] into y_out
   (n_save x N_Y): the step's own state where one ends on it, hermite_state between. With
   project (and constraints of order 0 or 1), each step's end is put back onto the constraints
   by project_state() before its rates are taken. counts (6) are added to as for dop853, and
   counts[5] the constraint evaluations of the projection. Returns GPMEGEN_OK, the status of a
   failed solve or projection, GPMEGEN_NO_CONVERGENCE, GPMEGEN_NONFINITE or
   GPMEGEN_BAD_ARGUMENTS; *n_saved counts the rows saved, also on a failure. */
int gpmegen_genalpha(const struct gpmegen_model *model, double t0, double dt, long n_steps, double t_end, long k_from,
                     long k_to, double rho_inf, int project, double *y_io, double *a_io, double *S, int *pivot,
                     int *have_matrix, long n_save, const double *t_save, const double *p, double *y_out,
                     long *n_saved, long *counts)
{
    const int N_DOF = model->n_dof, N_Z = model->n_controllers, N_R = N_DOF + N_Z;
    const int N_Y = 2 * N_DOF + 2 + N_Z, N_MOTION = 2 * N_DOF;
    const struct genalpha_parameters c = genalpha_parameters(rho_inf);
    double y[N_Y] ALIGNED, y_new[N_Y] ALIGNED, r[N_Y] ALIGNED, r_new[N_Y] ALIGNED;
    double a[N_DOF] ALIGNED, a_new[N_DOF] ALIGNED, base_q[N_DOF] ALIGNED, base_qd[N_DOF] ALIGNED;
    double qdd_before[N_DOF] ALIGNED;  /* qdd at the start of the step before (NaN: none) */
    /* the unknowns [qdd_{n+1}, z_{n+1}] and their Newton increments; base_z: z_n + (h / 2) r_n */
    double x[N_R] ALIGNED, dx[N_R] ALIGNED, base_z[AT_LEAST_1(N_Z)] ALIGNED;
    const int Z = N_MOTION + 2;  /* where z starts in y */
    long j = 0;
    int status;

    *n_saved = 0;
    if (k_from < 0 || k_to < k_from || n_steps < k_to || !isfinite(t0) || !(dt > 0.0) || !isfinite(t_end)
        || !(rho_inf >= 0.0 && rho_inf <= 1.0) || n_save < 0) {
        return GPMEGEN_BAD_ARGUMENTS;
    }
    for (int i = 0; i < N_Y; ++i) {
        y[i] = y_io[i];
    }
    if (!all_finite(y, N_Y)) {
        return GPMEGEN_NONFINITE;
    }
    ++counts[2];
    if ((status = gpmegen_state_rate(model, grid_time(t0, dt, n_steps, t_end, k_from), y, p, r))
        != GPMEGEN_OK) {
        return status;
    }
    for (int i = 0; i < N_DOF; ++i) {
        a[i] = isfinite(a_io[i]) ? a_io[i] : r[N_DOF + i];
        qdd_before[i] = a_io[N_DOF + i];
    }
    for (long k = k_from + 1; k <= k_to; ++k) {
        const double t = grid_time(t0, dt, n_steps, t_end, k - 1), t_new = grid_time(t0, dt, n_steps, t_end, k);
        const double h = t_new - t, da = (1.0 - c.alpha_f) / (1.0 - c.alpha_m);
        const double *qdd = r + N_DOF;
        int fresh = 0, converged = 0;
        /* the parts of q_{n+1} and qd_{n+1} known before the solve */
        for (int i = 0; i < N_DOF; ++i) {
            const double a_known = (c.alpha_f * qdd[i] - c.alpha_m * a[i]) / (1.0 - c.alpha_m);
            base_q[i] = y[i] + h * y[N_DOF + i] + h * h * ((0.5 - c.beta) * a[i] + c.beta * a_known);
            base_qd[i] = y[N_DOF + i] + h * ((1.0 - c.gamma) * a[i] + c.gamma * a_known);
        }
        for (int k = 0; k < N_Z; ++k) {
            base_z[k] = y[Z + k] + 0.5 * h * r[Z + k];
        }
        while (!converged) {
            if (!*have_matrix || fresh) {
                /* the Jacobian at the predictor qdd_{n+1} = qdd_n, z_{n+1} = z_n + h r_n */
                for (int i = 0; i < N_DOF; ++i) {
                    y_new[i] = base_q[i] + c.beta * h * h * da * qdd[i];
                    y_new[N_DOF + i] = base_qd[i] + c.gamma * h * da * qdd[i];
                }
                for (int k = 0; k < N_Z; ++k) {
                    y_new[Z + k] = y[Z + k] + h * r[Z + k];
                }
                *have_matrix = 0;
                if ((status = genalpha_matrix(model, t_new, y_new, h, c, p, S, pivot, counts)) != GPMEGEN_OK) {
                    return status;
                }
                *have_matrix = 1;
            }
            for (int i = 0; i < N_DOF; ++i) {
                x[i] = isfinite(qdd_before[i]) ? 2.0 * qdd[i] - qdd_before[i] : qdd[i];
            }
            for (int k = 0; k < N_Z; ++k) {
                x[N_DOF + k] = y[Z + k] + h * r[Z + k];
            }
            double previous = INFINITY;
            for (int iteration = 0; iteration < NEWTON_ITERATIONS; ++iteration) {
                for (int i = 0; i < N_DOF; ++i) {
                    y_new[i] = base_q[i] + c.beta * h * h * da * x[i];
                    y_new[N_DOF + i] = base_qd[i] + c.gamma * h * da * x[i];
                }
                for (int k = 0; k < N_Z; ++k) {
                    y_new[Z + k] = x[N_DOF + k];
                }
                ++counts[2];
                if ((status = gpmegen_state_rate(model, t_new, y_new, p, r_new)) != GPMEGEN_OK) {
                    return status;
                }
                double size = 0.0, scale = 1.0;
                for (int i = 0; i < N_DOF; ++i) {
                    dx[i] = r_new[N_DOF + i] - x[i];
                }
                for (int k = 0; k < N_Z; ++k) {
                    dx[N_DOF + k] = base_z[k] + 0.5 * h * r_new[Z + k] - x[N_DOF + k];
                }
                gpmegen_lu_solve(N_R, S, pivot, 1, dx);
                for (int i = 0; i < N_R; ++i) {
                    x[i] += dx[i];
                    size = fmax(size, fabs(dx[i]));
                    scale = fmax(scale, fabs(x[i]));
                }
                if (!isfinite(size) || size > NEWTON_RATE * previous) {
                    break;
                }
                /* the error left after this increment: theta / (1 - theta) of it (theta <= NEWTON_RATE) */
                const double left = iteration > 0 ? size * (size / previous) / (1.0 - size / previous) : size;
                previous = size;
                if (left <= NEWTON_TOLERANCE * scale) {
                    converged = 1;
                    break;
                }
            }
            if (!converged) {
                if (fresh) {
                    return GPMEGEN_NO_CONVERGENCE;
                }
                fresh = 1;
            }
        }
        /* the state at the converged qdd_{n+1}, and its rates */
        for (int i = 0; i < N_DOF; ++i) {
            a_new[i] = (c.alpha_f * qdd[i] - c.alpha_m * a[i] + (1.0 - c.alpha_f) * x[i]) / (1.0 - c.alpha_m);
            y_new[i] = base_q[i] + c.beta * h * h * da * x[i];
            y_new[N_DOF + i] = base_qd[i] + c.gamma * h * da * x[i];
        }
        for (int k = 0; k < N_Z; ++k) {
            y_new[Z + k] = x[N_DOF + k];
        }
        if (project && model->n_constraints > 0
            && (status = project_state(model, t_new, y_new, p, &counts[5])) != GPMEGEN_OK) {
            return status;
        }
        ++counts[2];
        if ((status = gpmegen_state_rate(model, t_new, y_new, p, r_new)) != GPMEGEN_OK) {
            return status;
        }
        for (int m = 0; m < 2; ++m) {
            y_new[N_MOTION + m] = y[N_MOTION + m] + 0.5 * h * (r[N_MOTION + m] + r_new[N_MOTION + m]);
        }
        if (!all_finite(y_new, N_Y)) {
            return GPMEGEN_NONFINITE;
        }
        ++counts[0];
        for (; j < n_save && t_save[j] <= t_new; ++j) {
            if (t_save[j] == t_new) {
                for (int i = 0; i < N_Y; ++i) {
                    y_out[j * N_Y + i] = y_new[i];
                }
            } else {
                hermite_state(N_Y, (t_save[j] - t) / h, h, y, r, y_new, r_new, y_out + j * N_Y);
            }
        }
        *n_saved = j;
        for (int i = 0; i < N_DOF; ++i) {
            qdd_before[i] = qdd[i];  /* qdd_n, before r holds qdd_{n+1} */
        }
        for (int i = 0; i < N_Y; ++i) {
            y[i] = y_new[i];
            r[i] = r_new[i];
        }
        for (int i = 0; i < N_DOF; ++i) {
            a[i] = a_new[i];
        }
    }
    for (int i = 0; i < N_Y; ++i) {
        y_io[i] = y[i];
    }
    for (int i = 0; i < N_DOF; ++i) {
        a_io[i] = a[i];
        a_io[N_DOF + i] = qdd_before[i];
    }
    return GPMEGEN_OK;
}
