/* RK4 steps of a compiled model library, for counting their instructions (which, unlike times,
   do not depend on the machine's load): valgrind's callgrind counts a run of 1 000 and one of
   3 000 steps, and the difference over 2 000 is the count per step, start-up and loading left out.

   Build and run (LIB: a model library of the C cache, e.g. printed by
   `python -c "import gpmegen; print(gpmegen.load('manipulator', nrfe=5, backend='c').evaluator.library.path)"`;
   PREFIX: its model's name, manipulator_nrfe5; P: a file of its parameter values, their count first,
   e.g. written by `python -c "import gpmegen; m = gpmegen.load('manipulator', nrfe=5); print(len(m.p), *m.p)"`):

       cc -O2 -o rk4_driver benchmarks/rk4_driver.c -ldl
       valgrind --tool=callgrind --callgrind-out-file=/dev/null ./rk4_driver LIB PREFIX P 1000
       valgrind --tool=callgrind --callgrind-out-file=/dev/null ./rk4_driver LIB PREFIX P 3000

   The state: q = 0 but the second coordinate (psi2 of the reference arm) at pi / 4, at rest. */

#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>

typedef int (*rk4_function)(double, double, long, double, long, long, long, const double *, const double *,
                            const double *, const double *, const int *, const int *, double *, double *, double *,
                            double *, long *);
typedef int (*size_function)(void);

int main(int argc, char **argv)
{
    char name[256];
    if (argc != 5) {
        fprintf(stderr, "usage: rk4_driver LIBRARY PREFIX PARAMETERS STEPS\n");
        return 2;
    }
    void *library = dlopen(argv[1], RTLD_NOW);
    if (library == NULL) {
        fprintf(stderr, "%s\n", dlerror());
        return 2;
    }
    snprintf(name, sizeof name, "%s_rk4", argv[2]);
    rk4_function rk4 = (rk4_function)dlsym(library, name);
    snprintf(name, sizeof name, "%s_n_dof", argv[2]);
    size_function n_dof = (size_function)dlsym(library, name);
    FILE *file = fopen(argv[3], "r");
    int n_parameters;
    if (rk4 == NULL || n_dof == NULL || file == NULL || fscanf(file, "%d", &n_parameters) != 1 || n_parameters < 1) {
        fprintf(stderr, "no %s_rk4 or %s_n_dof in %s, or no parameters in %s\n", argv[2], argv[2], argv[1], argv[3]);
        return 2;
    }
    const int n = n_dof();
    const long steps = atol(argv[4]);
    double *p = calloc((size_t)n_parameters, sizeof(double)), *state = calloc(8 * (size_t)n + 8, sizeof(double));
    for (int i = 0; i < n_parameters; ++i) {
        if (fscanf(file, "%lf", &p[i]) != 1) {
            return 2;
        }
    }
    double *q = state, *qd = q + n, *q_out = qd + n, *qd_out = q_out + 2 * n, *w = qd_out + 2 * n, *w_out = w + 2;
    double t_out[2];
    long saved;
    q[1] = 0.7853981633974483;
    const int status = rk4(0.0, 1e-5, steps, (double)steps * 1e-5, 0, steps, steps, q, qd, w, p, NULL, NULL, t_out,
                           q_out, qd_out, w_out, &saved);
    printf("status %d, q[1] at the end %.17g\n", status, q_out[n + 1]);
    return status;
}
