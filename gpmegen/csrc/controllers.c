/* The controller states z in the implicit integrators: the parameters with z in their place, and
   the Jacobian of the whole rate [qd, qdd, dz/dt] that the Newton matrices of radau.c and
   genalpha.c are made of. */

#include "solver_internal.h"

/* p with the controller states z in its last n_controllers entries (out: n_parameters +
   n_controllers), as gpmegen_stage puts them for the generated functions. */
void gpmegen_with_controllers(const struct gpmegen_model *model, const double *p, const double *z, double *out)
{
    for (int k = 0; k < model->n_parameters; ++k) {
        out[k] = p[k];
    }
    for (int j = 0; j < model->n_controllers; ++j) {
        out[model->n_parameters + j] = z[j];
    }
}

/* GPME solves one gpmegen_state_jacobian takes (as an integrator counts them). */
long gpmegen_state_jacobian_solves(const struct gpmegen_model *model)
{
    return gpmegen_jacobian_solves(model) + 2 * (long)model->n_controllers;
}

/* The Jacobian (N_Z x n, row-major) of the controller states' rates at (t, q, qd) and the z in
   p in the n entries x, which are q's, qd's or the z's in p (restored on return): central
   differences with steps cbrt(DBL_EPSILON) max(1, |x_j|). */
static void rate_columns(const struct gpmegen_model *model, double t, const double *q, const double *qd,
                         const double *p, double *x, int n, double *out)
{
    const int N_Z = model->n_controllers;
    double up[N_Z] ALIGNED, down[N_Z] ALIGNED;
    for (int j = 0; j < n; ++j) {
        const double h = cbrt(DBL_EPSILON) * fmax(1.0, fabs(x[j])), saved = x[j];
        x[j] = saved + h;
        model->controller_rates(t, q, qd, p, up);
        x[j] = saved - h;
        model->controller_rates(t, q, qd, p, down);
        x[j] = saved;
        for (int i = 0; i < N_Z; ++i) {
            out[i * n + j] = (up[i] - down[i]) / (2.0 * h);
        }
    }
}

/* At the state y = [q, qd, w, z] (N_Y) and time t: qdd (N_DOF), its Jacobians dqdd/dq, dqdd/dqd
   (A_q, A_qd: N_DOF x N_DOF, row-major, [i * N_DOF + j] = d qdd_i / d x_j) from
   gpmegen_gpme_jacobian (generated or differenced), and, for the controller states (N_Z =
   n_controllers, nothing written when 0), dqdd/dz (A_z: N_DOF x N_Z) and the Jacobians of their
   rates r(t, q, qd, z): R_q, R_qd (N_Z x N_DOF) and R_z (N_Z x N_Z), all four by central
   differences with steps cbrt(DBL_EPSILON) max(1, |x_j|) (as jacobian.c's differenced ones: the
   rates are generated functions with no derivatives emitted; 2 N_Z GPME solves, 4 N_DOF + 2 N_Z
   rates). Returns the status of a failed solve, else GPMEGEN_OK. */
int gpmegen_state_jacobian(const struct gpmegen_model *model, double t, const double *y, const double *p,
                           double *qdd, double *A_q, double *A_qd, double *A_z, double *R_q, double *R_qd,
                           double *R_z)
{
    const int N_DOF = model->n_dof, N_Z = model->n_controllers;
    const double *z = y + 2 * N_DOF + 2;
    double with_z[N_Z ? model->n_parameters + N_Z : 1] ALIGNED, q[N_DOF] ALIGNED, qd[N_DOF] ALIGNED;
    double up[N_DOF] ALIGNED, down[N_DOF] ALIGNED;
    double power;
    int status;
    if (N_Z == 0) {
        return gpmegen_gpme_jacobian(model, t, y, y + N_DOF, p, qdd, A_q, A_qd);
    }
    memcpy(q, y, sizeof q);
    memcpy(qd, y + N_DOF, sizeof qd);
    gpmegen_with_controllers(model, p, z, with_z);
    if ((status = gpmegen_gpme_jacobian(model, t, q, qd, with_z, qdd, A_q, A_qd)) != GPMEGEN_OK) {
        return status;
    }
    double *const zs = with_z + model->n_parameters;  /* the states the generated functions read */
    for (int j = 0; j < N_Z; ++j) {
        const double h = cbrt(DBL_EPSILON) * fmax(1.0, fabs(z[j]));
        zs[j] = z[j] + h;
        status = model->gpme_recursive(t, q, qd, with_z, up, &power);
        zs[j] = z[j] - h;
        if (status != GPMEGEN_OK || (status = model->gpme_recursive(t, q, qd, with_z, down, &power)) != GPMEGEN_OK) {
            return status;
        }
        zs[j] = z[j];
        for (int i = 0; i < N_DOF; ++i) {
            A_z[i * N_Z + j] = (up[i] - down[i]) / (2.0 * h);
        }
    }
    rate_columns(model, t, q, qd, with_z, q, N_DOF, R_q);
    rate_columns(model, t, q, qd, with_z, qd, N_DOF, R_qd);
    rate_columns(model, t, q, qd, with_z, zs, N_Z, R_z);
    return GPMEGEN_OK;
}
