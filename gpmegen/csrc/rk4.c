/* Fixed-step RK4 (the integrator of the paper), and the rates every integrator takes. */

#include "solver_internal.h"

/* A stage's qdd and the power of the inputs in the actuated realization (model->actuators set). */
static int actuated_stage(const struct gpmegen_model *model, double t, const double *q, const double *qd,
                          const double *p, double *qdd, double *power)
{
    const int N_DOF = model->n_dof;
    double M[N_DOF * N_DOF] ALIGNED, f[N_DOF] ALIGNED, u[AT_LEAST_1(model->n_constraints)] ALIGNED;
    return gpmegen_actuated_solve(model, t, q, qd, p, qdd, u, M, f, power);
}

/* One stage: qdd from the GPME (the model's recursion; with model->actuators, the actuated
   realization's solve), the power of the drive (qd . Q) and of the constraint forces
   (qd . (M qdd - f)) whose integrals close the energy balance, and the rates of the controller
   states z (power[2 ...]), which the generated functions read from the end of p. */
int gpmegen_stage(const struct gpmegen_model *model, double t, const double *q, const double *qd, const double *z,
                  const double *p, double *qdd, double *power)
{
    const int N_DOF = model->n_dof, N_Z = model->n_controllers;
    double Q[N_DOF] ALIGNED, with_z[N_Z ? model->n_parameters + N_Z : 1] ALIGNED;
    if (N_Z) {
        for (int k = 0; k < model->n_parameters; ++k) {
            with_z[k] = p[k];
        }
        for (int j = 0; j < N_Z; ++j) {
            with_z[model->n_parameters + j] = z[j];
        }
        p = with_z;
    }
    const int status = model->actuators ? actuated_stage(model, t, q, qd, p, qdd, &power[1])
                                        : model->gpme_recursive(t, q, qd, p, qdd, &power[1]);
    if (status != GPMEGEN_OK) {
        return status;
    }
    model->drive_forces(t, q, qd, p, Q);
    power[0] = 0.0;
    for (int i = 0; i < N_DOF; ++i) {
        power[0] += qd[i] * Q[i];
    }
    if (N_Z) {
        model->controller_rates(t, q, qd, p, power + 2);
    }
    return GPMEGEN_OK;
}

/* dy/dt (N_Y) at (t, y), y = [q, qd, w, z]: [qd, qdd, powers, dz/dt]; returns the status of the
   GPME solve. */
int gpmegen_state_rate(const struct gpmegen_model *model, double t, const double *y, const double *p, double *rate)
{
    const int N_DOF = model->n_dof;
    for (int i = 0; i < N_DOF; ++i) {
        rate[i] = y[N_DOF + i];
    }
    return gpmegen_stage(model, t, y, y + N_DOF, y + 2 * N_DOF + 2, p, rate + N_DOF, rate + 2 * N_DOF);
}

static void save_state(int N_DOF, int N_W, long k, double t, const double *q, const double *qd, const double *w,
                       double *t_out, double *q_out, double *qd_out, double *w_out)
{
    t_out[k] = t;
    for (int i = 0; i < N_DOF; ++i) {
        q_out[k * N_DOF + i] = q[i];
        qd_out[k * N_DOF + i] = qd[i];
    }
    for (int j = 0; j < N_W; ++j) {
        w_out[N_W * k + j] = w[j];
    }
}

/* The controller states of a stage: z + c * rate (N_Z), rate the powers' slots after the two works. */
static void stage_controllers(int N_Z, const double *z, double c, const double *power, double *out)
{
    for (int j = 0; j < N_Z; ++j) {
        out[j] = z[j] + c * power[2 + j];
    }
}

/* One classical RK4 step of length h from t, in place on the state (q, qd, w), with qdd from
   the GPME and w the work of the drive and of the constraint forces (J), then the controller
   states (n_controllers). Returns GPMEGEN_OK, or the status of the first failed stage (the state
   is then left as it was). */
static int rk4_step(const struct gpmegen_model *model, double t, double h, double *q, double *qd, double *w,
                    const double *p)
{
    const int N_DOF = model->n_dof, N_Z = model->n_controllers, N_W = 2 + N_Z;
    double qs[N_DOF] ALIGNED, qds[N_DOF] ALIGNED, k1[N_DOF] ALIGNED, k2[N_DOF] ALIGNED;
    double k3[N_DOF] ALIGNED, k4[N_DOF] ALIGNED, p1[N_W] ALIGNED, p2[N_W] ALIGNED, p3[N_W] ALIGNED, p4[N_W] ALIGNED;
    double zs[N_Z ? N_Z : 1] ALIGNED;
    const double half = 0.5 * h, sixth = h / 6.0;
    const double *z = w + 2;
    int status;

    /* k1..k4 are the accelerations; the velocity slopes are the stage velocities. */
    if ((status = gpmegen_stage(model, t, q, qd, z, p, k1, p1)) != GPMEGEN_OK) {
        return status;
    }
    for (int i = 0; i < N_DOF; ++i) {
        qs[i] = q[i] + half * qd[i];
        qds[i] = qd[i] + half * k1[i];
    }
    stage_controllers(N_Z, z, half, p1, zs);
    if ((status = gpmegen_stage(model, t + half, qs, qds, zs, p, k2, p2)) != GPMEGEN_OK) {
        return status;
    }
    for (int i = 0; i < N_DOF; ++i) {
        qs[i] = q[i] + half * (qd[i] + half * k1[i]);
        qds[i] = qd[i] + half * k2[i];
    }
    stage_controllers(N_Z, z, half, p2, zs);
    if ((status = gpmegen_stage(model, t + half, qs, qds, zs, p, k3, p3)) != GPMEGEN_OK) {
        return status;
    }
    for (int i = 0; i < N_DOF; ++i) {
        qs[i] = q[i] + h * (qd[i] + half * k2[i]);
        qds[i] = qd[i] + h * k3[i];
    }
    stage_controllers(N_Z, z, h, p3, zs);
    if ((status = gpmegen_stage(model, t + h, qs, qds, zs, p, k4, p4)) != GPMEGEN_OK) {
        return status;
    }
    for (int i = 0; i < N_DOF; ++i) {
        /* velocity slopes: qd, qd + h/2 k1, qd + h/2 k2, qd + h k3 */
        q[i] += sixth * (qd[i] + 2.0 * (qd[i] + half * k1[i]) + 2.0 * (qd[i] + half * k2[i])
                         + (qd[i] + h * k3[i]));
        qd[i] += sixth * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    for (int j = 0; j < N_W; ++j) {
        w[j] += sixth * (p1[j] + 2.0 * p2[j] + 2.0 * p3[j] + p4[j]);
    }
    return GPMEGEN_OK;
}

/* Classical RK4 over steps k_from + 1 .. k_to of the grid of grid_time() (n_steps steps of dt
   from t0, the last one ending at t_end), from the state q0, qd0 (N_DOF) and w0 (N_W = 2 +
   n_controllers: the work, J, and the controller states) at the end of step k_from. Step k is dt long, the last one grid_time(n_steps) - grid_time(n_steps
   - 1). Saves the state at the start, after every step k that is a multiple of save_every and
   after step k_to (the final state, also off that grid) into t_out (n_save), q_out and qd_out
   (n_save x N_DOF) and w_out (n_save x N_W), with n_save = k_to / save_every - k_from /
   save_every + 2 at most; *n_saved counts the saved states. Returns GPMEGEN_OK when done,
   GPMEGEN_SINGULAR at the first singular solve, GPMEGEN_NONFINITE at the first non-finite state
   or stage (not saved), GPMEGEN_BAD_ARGUMENTS for invalid arguments; what was saved before a
   failure is kept. */
int gpmegen_rk4(const struct gpmegen_model *model, double t0, double dt, long n_steps, double t_end, long k_from,
                long k_to, long save_every, const double *q0, const double *qd0, const double *w0, const double *p,
                double *t_out, double *q_out, double *qd_out, double *w_out, long *n_saved)
{
    const int N_DOF = model->n_dof, N_W = 2 + model->n_controllers;
    double q[N_DOF] ALIGNED, qd[N_DOF] ALIGNED, w[N_W] ALIGNED;
    long saved = 0;
    int status;

    *n_saved = 0;
    if (k_from < 0 || k_to < k_from || n_steps < k_to || save_every < 1 || !isfinite(t0) || !isfinite(dt)
        || !(dt > 0.0) || !isfinite(t_end) || t_end < grid_time(t0, dt, n_steps, t_end, n_steps - 1)) {
        return GPMEGEN_BAD_ARGUMENTS;
    }
    for (int i = 0; i < N_DOF; ++i) {
        q[i] = q0[i];
        qd[i] = qd0[i];
    }
    for (int j = 0; j < N_W; ++j) {
        w[j] = w0[j];
    }
    if (!all_finite(q, N_DOF) || !all_finite(qd, N_DOF) || !all_finite(w, N_W)) {
        return GPMEGEN_NONFINITE;
    }
    save_state(N_DOF, N_W, saved++, grid_time(t0, dt, n_steps, t_end, k_from), q, qd, w, t_out, q_out, qd_out,
               w_out);
    *n_saved = saved;

    for (long k = k_from + 1; k <= k_to; ++k) {
        const double t = grid_time(t0, dt, n_steps, t_end, k - 1);
        const double h = k == n_steps ? t_end - t : dt;
        if ((status = rk4_step(model, t, h, q, qd, w, p)) != GPMEGEN_OK) {
            return status;
        }
        if (!all_finite(q, N_DOF) || !all_finite(qd, N_DOF) || !all_finite(w + 2, N_W - 2)) {
            return GPMEGEN_NONFINITE;
        }
        if (k % save_every == 0 || k == k_to) {
            save_state(N_DOF, N_W, saved++, grid_time(t0, dt, n_steps, t_end, k), q, qd, w, t_out, q_out, qd_out, w_out);
            *n_saved = saved;
        }
    }
    return GPMEGEN_OK;
}
