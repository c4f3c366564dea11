/* DOP853: Dormand-Prince 8(5,3), adaptive, with its dense output of order 7, and the first step
   of the adaptive integrators. The state y = [q, qd, w] (N_Y): w the work of the drive and of the
   constraint forces (J), integrated with the motion but not part of the error estimate (it
   follows the motion). */

#include "solver_internal.h"

/* The tableau of Dormand and Prince's 8(5,3) pair (Hairer, Norsett and Wanner, Solving Ordinary
   Differential Equations I, sec. II.10): nodes C, the 12 stages A of the step and the 3 extra
   stages of the dense output (rows 13-15), the weights B of order 8, the error estimators E5
   (order 5) and E3 (order 3) over the 13 stages (the 13th is f at the step's end), and D, the
   dense output's coefficients of order 7. */
static const double DOP_C[16] = {
    0.0, 0.05260015195876773, 0.0789002279381516, 0.1183503419072274, 0.2816496580927726,
    0.3333333333333333, 0.25, 0.3076923076923077, 0.6512820512820513, 0.6, 0.8571428571428571, 1.0,
    1.0, 0.1, 0.2, 0.7777777777777778
};
static const double DOP_B[12] = {
    0.054293734116568765, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003,
    -5.801203960010585, 0.3111643669578199, -0.1521609496625161, 0.20136540080403034,
    0.04471061572777259
};
static const double DOP_E3[13] = {
    -0.18980075407240762, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003,
    -5.801203960010585, -0.4226823213237919, -0.1521609496625161, 0.20136540080403034,
    0.02265179219836082, 0.0
};
static const double DOP_E5[13] = {
    0.01312004499419488, 0.0, 0.0, 0.0, 0.0, -1.2251564463762044, -0.4957589496572502,
    1.6643771824549864, -0.35032884874997366, 0.3341791187130175, 0.08192320648511571,
    -0.022355307863886294, 0.0
};
static const double DOP_A[16][16] = {
    {0.0},
    {0.05260015195876773},
    {0.0197250569845379, 0.0591751709536137},
    {0.02958758547680685, 0.0, 0.08876275643042054},
    {0.2413651341592667, 0.0, -0.8845494793282861, 0.924834003261792},
    {0.037037037037037035, 0.0, 0.0, 0.17082860872947386, 0.12546768756682242},
    {0.037109375, 0.0, 0.0, 0.17025221101954405, 0.06021653898045596, -0.017578125},
    {0.03709200011850479, 0.0, 0.0, 0.17038392571223998, 0.10726203044637328, -0.015319437748624402, 0.008273789163814023},
    {0.6241109587160757, 0.0, 0.0, -3.3608926294469414, -0.868219346841726, 27.59209969944671, 20.154067550477894, -43.48988418106996},
    {0.47766253643826434, 0.0, 0.0, -2.4881146199716677, -0.590290826836843, 21.230051448181193, 15.279233632882423, -33.28821096898486, -0.020331201708508627},
    {-0.9371424300859873, 0.0, 0.0, 5.186372428844064, 1.0914373489967295, -8.149787010746927, -18.52006565999696, 22.739487099350505, 2.4936055526796523, -3.0467644718982196},
    {2.273310147516538, 0.0, 0.0, -10.53449546673725, -2.0008720582248625, -17.9589318631188, 27.94888452941996, -2.8589982771350235, -8.87285693353063, 12.360567175794303, 0.6433927460157636},
    {0.054293734116568765, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003, -5.801203960010585, 0.3111643669578199, -0.1521609496625161, 0.20136540080403034, 0.04471061572777259},
    {0.056167502283047954, 0.0, 0.0, 0.0, 0.0, 0.0, 0.25350021021662483, -0.2462390374708025, -0.12419142326381637, 0.15329179827876568, 0.00820105229563469, 0.007567897660545699, -0.008298},
    {0.03183464816350214, 0.0, 0.0, 0.0, 0.0, 0.028300909672366776, 0.053541988307438566, -0.05492374857139099, 0.0, 0.0, -0.00010834732869724932, 0.0003825710908356584, -0.00034046500868740456, 0.1413124436746325},
    {-0.42889630158379194, 0.0, 0.0, 0.0, 0.0, -4.697621415361164, 7.683421196062599, 4.06898981839711, 0.3567271874552811, 0.0, 0.0, 0.0, -0.0013990241651590145, 2.9475147891527724, -9.15095847217987},
};
static const double DOP_D[4][16] = {
    {
        -8.428938276109013, 0.0, 0.0, 0.0, 0.0, 0.5667149535193777, -3.0689499459498917, 2.38466765651207,
        2.117034582445028, -0.871391583777973, 2.2404374302607883, 0.6315787787694688,
        -0.08899033645133331, 18.148505520854727, -9.194632392478356, -4.436036387594894},
    {
        10.427508642579134, 0.0, 0.0, 0.0, 0.0, 242.28349177525817, 165.20045171727028, -374.5467547226902,
        -22.113666853125306, 7.733432668472264, -30.674084731089398, -9.332130526430229,
        15.697238121770845, -31.139403219565178, -9.35292435884448, 35.81684148639408},
    {
        19.985053242002433, 0.0, 0.0, 0.0, 0.0, -387.0373087493518, -189.17813819516758, 527.8081592054236,
        -11.57390253995963, 6.8812326946963, -1.0006050966910838, 0.7777137798053443, -2.778205752353508,
        -60.19669523126412, 84.32040550667716, 11.99229113618279},
    {
        -25.69393346270375, 0.0, 0.0, 0.0, 0.0, -154.18974869023643, -231.5293791760455, 357.6391179106141,
        93.40532418362432, -37.45832313645163, 104.0996495089623, 29.8402934266605, -43.53345659001114,
        96.32455395918828, -39.17726167561544, -149.72683625798564},
};

enum { DOP_STAGES = 12, DOP_STAGES_DENSE = 16 };

/* Step control: safety factor, the bounds of one change of the step, and -1/8, the exponent of
   the error norm (the estimate is of order 7 in h). */
static const double DOP_SAFETY = 0.9, DOP_MIN_FACTOR = 0.2, DOP_MAX_FACTOR = 10.0, DOP_EXPONENT = -1.0 / 8.0;

/* The root mean square of x / scale over the motion (N_MOTION components). */
static double rms_scaled(int N_MOTION, const double *x, const double *y, double rtol, double atol)
{
    double s = 0.0;
    for (int i = 0; i < N_MOTION; ++i) {
        const double r = x[i] / error_scale(rtol, atol, y[i], y[i]);
        s += r * r;
    }
    return sqrt(s / N_MOTION);
}

/* The first step from (t, y) with rate f0, as Hairer's dop853 chooses it (Hairer, Norsett and
   Wanner I, sec. II.4): 1e-2 |y| / |f| in the scaled norm, checked against a second rate one
   such step ahead; *evaluations counts the rates taken. Returns GPMEGEN_OK or the status of that rate. */
int gpmegen_first_step(const struct gpmegen_model *model, double t, const double *y, const double *f0, double rtol,
                       double atol, double span, const double *p, double *h, long *evaluations)
{
    const int N_Y = 2 * model->n_dof + 2 + model->n_controllers, N_MOTION = 2 * model->n_dof;
    double y1[N_Y] ALIGNED, f1[N_Y] ALIGNED, df[N_MOTION] ALIGNED;
    const double d0 = rms_scaled(N_MOTION, y, y, rtol, atol), d1 = rms_scaled(N_MOTION, f0, y, rtol, atol);
    double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    int status;
    h0 = fmin(h0, span);
    for (int i = 0; i < N_Y; ++i) {
        y1[i] = y[i] + h0 * f0[i];
    }
    ++*evaluations;
    if ((status = gpmegen_state_rate(model, t + h0, y1, p, f1)) != GPMEGEN_OK) {
        return status;
    }
    for (int i = 0; i < N_MOTION; ++i) {
        df[i] = f1[i] - f0[i];
    }
    const double d2 = rms_scaled(N_MOTION, df, y, rtol, atol) / h0;
    const double h1 = (d1 <= 1e-15 && d2 <= 1e-15) ? fmax(1e-6, h0 * 1e-3) : pow(0.01 / fmax(d1, d2), 1.0 / 8.0);
    *h = fmin(fmin(100.0 * h0, h1), span);
    return GPMEGEN_OK;
}

/* y_old + dy with dy = h sum_s a[s] K[s] over the first n_stages rates K (each N_Y). */
static void stage_state(int N_Y, const double *y_old, double h, const double *a, int n_stages,
                        const double K[][N_Y], double *out)
{
    for (int i = 0; i < N_Y; ++i) {
        double s = 0.0;
        for (int j = 0; j < n_stages; ++j) {
            s += a[j] * K[j][i];
        }
        out[i] = y_old[i] + h * s;
    }
}

/* The dense output's polynomial of the step from (t, y_old) to y_new of length h: the 3 extra
   stages into K[13..15] (so K holds 16 rates, K[12] the rate at the step's end), then the 7
   coefficient vectors F (7 x N_Y) of y(t + x h) = y_old + sum over the nested form of
   dense_value. Returns GPMEGEN_OK or the status of an extra stage's rate. */
static int dop853_dense(const struct gpmegen_model *model, int N_Y, double t, double h, const double *y_old,
                        const double *y_new, double K[][N_Y], const double *p, double F[][N_Y], long *evaluations)
{
    double ys[N_Y] ALIGNED;
    int status;
    for (int s = DOP_STAGES + 1; s < DOP_STAGES_DENSE; ++s) {
        stage_state(N_Y, y_old, h, DOP_A[s], s, (const double (*)[N_Y])K, ys);
        ++*evaluations;
        if ((status = gpmegen_state_rate(model, t + DOP_C[s] * h, ys, p, K[s])) != GPMEGEN_OK) {
            return status;
        }
    }
    for (int i = 0; i < N_Y; ++i) {
        const double delta = y_new[i] - y_old[i];
        F[0][i] = delta;
        F[1][i] = h * K[0][i] - delta;
        F[2][i] = 2.0 * delta - h * (K[DOP_STAGES][i] + K[0][i]);
        for (int r = 0; r < 4; ++r) {
            double s = 0.0;
            for (int j = 0; j < DOP_STAGES_DENSE; ++j) {
                s += DOP_D[r][j] * K[j][i];
            }
            F[3 + r][i] = h * s;
        }
    }
    return GPMEGEN_OK;
}

/* y at t_old + x h (0 <= x <= 1) from the dense output's coefficients F of the step from y_old:
   y_old + x (F0 + (1 - x) (F1 + x (F2 + (1 - x) (F3 + ...)))). */
static void dense_value(int N_Y, double x, const double *y_old, const double F[][N_Y], double *out)
{
    for (int i = 0; i < N_Y; ++i) {
        double s = 0.0;
        for (int r = 6; r >= 0; --r) {
            s += F[r][i];
            s *= (r % 2 == 0) ? x : 1.0 - x;
        }
        out[i] = y_old[i] + s;
    }
}

/* What a call of DOP853 that stopped before its last saved instant (max_steps spent) leaves
   for the next to go on from, bit for bit as if it had not stopped: the time t, the state y and
   its rate, the saved rows k so far and whether the last step was rejected. started: 0 (all
   zero bytes) before the first call of a span.
The memory holds a struct dop853_place, then y and its rate (N_Y each). */
struct dop853_place {
    double t;
    long k;
    int started, rejected;
};

/* The bytes of the memory, which the caller holds between calls. */
long gpmegen_dop853_memory_bytes(const struct gpmegen_model *model)
{
    return (long)(sizeof(struct dop853_place)
                  + 2 * (size_t)(2 * model->n_dof + 2 + model->n_controllers) * sizeof(double));
}

/* DOP853 from (t_a, y_a) (y = [q, qd, w, z], N_Y: z the controller states) to t_save[n_save - 1],
   saving y at each of the n_save increasing instants t_save (all after t_a) into y_out (n_save x
   N_Y): the step's own state where a step ends on one (always the last, where the last step is
   cut to end), the dense output of order 7 between. The error of each step, in the root mean
   square over q, qd and z of err / (atol + rtol |y|), is kept below 1. *h: in, the step to try first (<= 0: chosen
   here); out, the step to try next. max_steps > 0: the call returns GPMEGEN_OK with *n_saved <
   n_save after that many steps (accepted or rejected), its place kept in memory
   (gpmegen_dop853_memory_bytes(), zeroed by the caller before the span's first call), and the next call with the
   same arguments goes on from there (t_a and y_a are then not read, and y_out only written from
   row *n_saved on); 0: no limit, memory may be NULL. counts (5) are added to: steps accepted,
   steps rejected, rates (GPME solves of the state), Jacobians and LU factorizations (none
   here). Returns GPMEGEN_OK; the status of a failed rate; GPMEGEN_NONFINITE at a non-finite
   state; GPMEGEN_STEP_TOO_SMALL when the step fell to round-off of t; GPMEGEN_BAD_ARGUMENTS.
   *n_saved counts the saved rows of the span, also on a failure. */
int gpmegen_dop853(const struct gpmegen_model *model, double t_a, const double *y_a, long n_save,
                   const double *t_save, double rtol, double atol, double *h, long max_steps, void *memory,
                   const double *p, double *y_out, long *n_saved, long *counts)
{
    const int N_Y = 2 * model->n_dof + 2 + model->n_controllers, N_MOTION = 2 * model->n_dof;
    /* the components whose error is kept: q, qd and the controller states (not the work) */
    const int N_ERROR = N_MOTION + model->n_controllers;
    double K[DOP_STAGES_DENSE][N_Y] ALIGNED, F[7][N_Y] ALIGNED;
    double y_new[N_Y] ALIGNED, err5[N_ERROR] ALIGNED, err3[N_ERROR] ALIGNED;
    double y[N_Y] ALIGNED, run_rate[N_Y] ALIGNED;
    const size_t state_bytes = (size_t)N_Y * sizeof(double);
    struct dop853_place run;
    int status;
    long taken = 0;

    *n_saved = 0;
    if (n_save < 1 || !isfinite(t_a) || !(rtol > 0.0) || !(atol >= 0.0) || !isfinite(*h) || max_steps < 0
        || (max_steps > 0 && memory == NULL)) {
        return GPMEGEN_BAD_ARGUMENTS;
    }
    for (long j = 0; j < n_save; ++j) {
        if (!isfinite(t_save[j]) || !(t_save[j] > (j ? t_save[j - 1] : t_a))) {
            return GPMEGEN_BAD_ARGUMENTS;
        }
    }
    const double t_b = t_save[n_save - 1];
    if (memory != NULL) {
        memcpy(&run, memory, sizeof run);
        memcpy(y, (const char *)memory + sizeof run, state_bytes);
        memcpy(run_rate, (const char *)memory + sizeof run + state_bytes, state_bytes);
    } else {
        run.started = 0;
    }
    if (run.started) {  /* going on from the call before */
        if (!(run.k >= 0 && run.k < n_save && run.t >= t_a && run.t < t_b)) {
            return GPMEGEN_BAD_ARGUMENTS;
        }
        *n_saved = run.k;
        for (int i = 0; i < N_Y; ++i) {
            K[0][i] = run_rate[i];
        }
    } else {
        run.t = t_a;
        run.k = 0;
        run.rejected = 0;
        for (int i = 0; i < N_Y; ++i) {
            y[i] = y_a[i];
        }
        if (!all_finite(y, N_Y)) {
            return GPMEGEN_NONFINITE;
        }
        ++counts[2];
        if ((status = gpmegen_state_rate(model, run.t, y, p, K[0])) != GPMEGEN_OK) {
            return status;
        }
        if (!(*h > 0.0) && (status = gpmegen_first_step(model, run.t, y, K[0], rtol, atol, t_b - t_a, p, h,
                                                        &counts[2])) != GPMEGEN_OK) {
            return status;
        }
    }
    double t = run.t;
    long k = run.k;
    int rejected = run.rejected;
    while (k < n_save) {
        if (max_steps > 0 && taken == max_steps) {  /* the caller's turn: the place kept for the next call */
            run.t = t;
            run.k = k;
            run.rejected = rejected;
            run.started = 1;
            for (int i = 0; i < N_Y; ++i) {
                run_rate[i] = K[0][i];
            }
            memcpy(memory, &run, sizeof run);
            memcpy((char *)memory + sizeof run, y, state_bytes);
            memcpy((char *)memory + sizeof run + state_bytes, run_rate, state_bytes);
            return GPMEGEN_OK;
        }
        ++taken;
        const int last = t + *h >= t_b;
        const double step = last ? t_b - t : *h;
        const double t_new = last ? t_b : t + step;
        if (step <= 10.0 * (nextafter(t, INFINITY) - t)) {
            return GPMEGEN_STEP_TOO_SMALL;
        }
        for (int s = 1; s < DOP_STAGES; ++s) {
            stage_state(N_Y, y, step, DOP_A[s], s, (const double (*)[N_Y])K, y_new);
            ++counts[2];
            if ((status = gpmegen_state_rate(model, t + DOP_C[s] * step, y_new, p, K[s])) != GPMEGEN_OK) {
                return status;
            }
        }
        stage_state(N_Y, y, step, DOP_B, DOP_STAGES, (const double (*)[N_Y])K, y_new);
        ++counts[2];
        if ((status = gpmegen_state_rate(model, t_new, y_new, p, K[DOP_STAGES])) != GPMEGEN_OK) {
            return status;
        }
        /* the error estimate of Hairer's dop853: the order-5 one, kept from growing where the
           order-3 one is small compared with it */
        double n5 = 0.0, n3 = 0.0;
        for (int e = 0; e < N_ERROR; ++e) {
            const int i = e < N_MOTION ? e : e + 2;   /* past the two works */
            double e5 = 0.0, e3 = 0.0;
            for (int s = 0; s <= DOP_STAGES; ++s) {
                e5 += DOP_E5[s] * K[s][i];
                e3 += DOP_E3[s] * K[s][i];
            }
            const double scale = error_scale(rtol, atol, y[i], y_new[i]);
            err5[e] = e5 / scale;
            err3[e] = e3 / scale;
            n5 += err5[e] * err5[e];
            n3 += err3[e] * err3[e];
        }
        const double denominator = n5 + 0.01 * n3;
        const double error = denominator > 0.0 ? step * n5 / sqrt(denominator * N_ERROR) : 0.0;
        if (!isfinite(error) || !all_finite(y_new, N_Y)) {
            return GPMEGEN_NONFINITE;
        }
        if (error >= 1.0) {
            *h = step * fmax(DOP_MIN_FACTOR, DOP_SAFETY * pow(error, DOP_EXPONENT));
            ++counts[1];
            rejected = 1;
            continue;
        }
        double factor = error == 0.0 ? DOP_MAX_FACTOR : fmin(DOP_MAX_FACTOR, DOP_SAFETY * pow(error, DOP_EXPONENT));
        if (rejected) {
            factor = fmin(1.0, factor);
        }
        /* a step cut short to end on t_b says nothing against the longer one it replaced */
        *h = last ? fmax(*h, step * factor) : step * factor;
        rejected = 0;
        ++counts[0];
        int dense = 0;
        for (; k < n_save && t_save[k] <= t_new; ++k) {
            if (t_save[k] == t_new) {
                for (int i = 0; i < N_Y; ++i) {
                    y_out[k * N_Y + i] = y_new[i];
                }
                continue;
            }
            if (!dense) {
                if ((status = dop853_dense(model, N_Y, t, step, y, y_new, K, p, F, &counts[2]))
                    != GPMEGEN_OK) {
                    return status;
                }
                dense = 1;
            }
            dense_value(N_Y, (t_save[k] - t) / step, y, (const double (*)[N_Y])F, y_out + k * N_Y);
        }
        *n_saved = k;
        t = t_new;
        for (int i = 0; i < N_Y; ++i) {
            y[i] = y_new[i];
            K[0][i] = K[DOP_STAGES][i];
        }
    }
    return GPMEGEN_OK;
}
