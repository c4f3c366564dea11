/* One call of the solver library (gpmegen/csrc) on a model of n uncoupled unit oscillators,
   qdd_i = -q_i, whose recursion falls back to the dense solve as a generated model's does (its M
   and f on the stack, then gpmegen_gpme_solve): run as "stack_probe CALL N" with CALL one of
   solve, jacobian, rk4, dop853, radau, genalpha, actuated, actuated_rk4, actuated_dop853 (the actuated
   realization's solve, RK4 and DOP853; tests/test_c_stack.py runs it under a stack limit).
   Prints "ok CALL N STATUS" and exits 0 when the call returns. */

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gpmegen_solver.h"

static int N;
static struct gpmegen_model model;

static void terms(double t, const double *q, const double *qd, const double *p, double *M, double *f,
                  double *phi, double *phi_rate, double *D, double *gamma)
{
    (void)t, (void)qd, (void)p, (void)phi, (void)phi_rate, (void)D, (void)gamma;
    memset(M, 0, sizeof(double) * (size_t)N * (size_t)N);
    for (int i = 0; i < N; ++i) {
        M[i * N + i] = 1.0;
        f[i] = -q[i];
    }
}

static void constraint_terms(double t, const double *q, const double *qd, const double *p, double *phi,
                             double *phi_rate, double *D, double *gamma)
{
    (void)t, (void)q, (void)qd, (void)p, (void)phi, (void)phi_rate, (void)D, (void)gamma;
}

static void gains(const double *p, double *alpha, double *beta)
{
    (void)p, (void)alpha, (void)beta;
}

static void drive(double t, const double *q, const double *qd, const double *p, double *Q)
{
    (void)t, (void)q, (void)qd, (void)p;
    memset(Q, 0, sizeof(double) * (size_t)N);
}

static int recursive(double t, const double *q, const double *qd, const double *p, double *qdd, double *power)
{
    double M[N * N], f[N];
    return gpmegen_gpme_solve(&model, t, q, qd, p, qdd, M, f, power);
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: stack_probe CALL N\n");
        return 2;
    }
    const char *call = argv[1];
    N = atoi(argv[2]);
    model = (struct gpmegen_model){ N, 0, NULL, terms, constraint_terms, gains, drive, recursive, NULL };
    const size_t n = (size_t)N, ny = 2 * n + 2;
    double *y = calloc(ny, sizeof(double)), *y_out = calloc(4 * ny, sizeof(double));
    double *a = calloc(2 * n, sizeof(double)), *A = calloc(n * n, sizeof(double)), *B = calloc(n * n, sizeof(double));
    int *pivot = calloc(n, sizeof(int)), have = 0;
    double p[1] = { 0.0 }, t_save[1] = { 1e-3 }, h = 0.0, power = 0.0, w0[2] = { 0.0, 0.0 }, t_out[4];
    long n_saved = 0, counts[8] = { 0 };
    for (size_t i = 0; i < n; ++i) {
        y[i] = 0.1;
        a[i] = a[n + i] = NAN;  /* genalpha's a_io: a and the qdd of the step before */
    }
    int status = -1;
    if (!strcmp(call, "solve")) {
        status = recursive(0.0, y, y + n, p, a, &power);
    } else if (!strcmp(call, "jacobian")) {
        status = gpmegen_gpme_jacobian(&model, 0.0, y, y + n, p, a, A, B);
    } else if (!strcmp(call, "rk4")) {
        status = gpmegen_rk4(&model, 0.0, 1e-3, 2, 2e-3, 0, 2, 1, y, y + n, w0, p, t_out, A, B, y_out, &n_saved);
    } else if (!strcmp(call, "dop853") || !strcmp(call, "radau")) {
        const int radau = !strcmp(call, "radau");
        void *memory = calloc(1, (size_t)(radau ? gpmegen_radau_memory_bytes(&model)
                                                : gpmegen_dop853_memory_bytes(&model)));
        status = (radau ? gpmegen_radau : gpmegen_dop853)(&model, 0.0, y, 1, t_save, 1e-6, 1e-8, &h, 0, memory, p,
                                                            y_out, &n_saved, counts);
    } else if (!strcmp(call, "genalpha")) {
        status = gpmegen_genalpha(&model, 0.0, 1e-3, 1, 1e-3, 0, 1, 0.8, 0, y, a, A, pivot, &have, 1, t_save, p,
                                  y_out, &n_saved, counts);
    } else if (!strcmp(call, "actuated") || !strcmp(call, "actuated_rk4") || !strcmp(call, "actuated_dop853")) {
        static const int no_actuators[1] = { 0 };  /* no constraints: no inputs */
        struct gpmegen_model actuated = model;
        double u[1];
        actuated.actuators = no_actuators;
        if (!strcmp(call, "actuated")) {
            status = gpmegen_actuated_solve(&actuated, 0.0, y, y + n, p, a, u, A, B, &power);
        } else if (!strcmp(call, "actuated_rk4")) {
            status = gpmegen_rk4(&actuated, 0.0, 1e-3, 2, 2e-3, 0, 2, 1, y, y + n, w0, p, t_out, A, B, y_out,
                                 &n_saved);
        } else {
            status = gpmegen_dop853(&actuated, 0.0, y, 1, t_save, 1e-6, 1e-8, &h, 0, NULL, p, y_out, &n_saved,
                                    counts);
        }
    } else {
        fprintf(stderr, "unknown call %s\n", call);
        return 2;
    }
    printf("ok %s %d %d\n", call, N, status);
    return 0;
}
