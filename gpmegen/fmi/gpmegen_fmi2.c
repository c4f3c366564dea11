/* gpmegen's FMU: the FMI 2.0 functions of Model Exchange and Co-Simulation, served by a model's
   generated C (model.c, its functions declared in model.h) and gpmegen's solver library (the
   GPME's dense solve, RK4, DOP853). What differs between models is in fmu_model.h, written by
   gpmegen.codegen.backends.fmu: the sizes, the model's function names, the value references, the
   start values and the GUID of modelDescription.xml.

   The model's exported names are <model name>_<function>: no name here ends like one of those
   ("_gpme_terms", "_points", ...), and fmu_model.h's include guard does not end in "_MODEL_H" as
   model.h's does, so that no model name meets them.

   The real variables live in one array v, indexed by value reference:
       q (N_DOF), qd (N_DOF)                   the continuous states, in the model's order
       der(q) (N_DOF), der(qd) (N_DOF)         their derivatives: qd and the GPME's qdd
       p (N_PARAMETERS), u (N_INPUTS)          the parameters, then the inputs
       points (3 N_POINTS), lambda, phi (N_CONSTRAINTS each)   the outputs
       integrator step, rtol, atol             the Co-Simulation's integrator
   so that v + VR_P is the extended parameter vector [p, u] that the generated functions take (they
   read its first N_PARAMETERS entries) and that terms_with_inputs below reads the inputs from: the
   input u_k is a generalized force added to f on coordinate INPUT_COORDINATES[k], as the
   CasADi export's u. The one integer variable, the integrator's method (0 rk4, 1 dop853), has
   value reference VR_METHOD. */

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gpmegen_fmi2.h"
#include "gpmegen_solver.h"
#include "fmu_model.h"

#define N_MOTION (2 * N_DOF)
#define N_Y (2 * N_DOF + 2)
#define METHOD_RK4 0
#define METHOD_DOP853 1
/* Relative difference of a communication step from a whole number of integrator steps taken as
   round-off (gpmegen.runtime.integrators.loop.STEP_ROUND_OFF). */
#define STEP_ROUND_OFF 1e-6

enum fmu_phase { INSTANTIATED, INITIALIZATION, STEPPING, TERMINATED, FAILED };

struct fmu_instance {
    fmi2Type type;
    enum fmu_phase phase;
    fmi2CallbackFunctions callbacks;
    char *name;
    int logging;
    double t;
    double v[N_REALS];
    int method;
    int current;          /* v's derivatives and outputs are those of its states, time, p and u */
    int status;           /* the gpmegen status of the last evaluation */
    double h_dop853;      /* DOP853's next step, kept between communication steps */
    double M[N_DOF * N_DOF], f[N_DOF];
};

/* The model's GPME terms with the inputs: f += S u, u after the parameters in p. */
static void terms_with_inputs(double t, const double *q, const double *qd, const double *p, double *M, double *f,
                           double *phi, double *phi_rate, double *D, double *gamma)
{
    MODEL_GPME_TERMS(t, q, qd, p, M, f, phi, phi_rate, D, gamma);
#if N_INPUTS > 0
    for (int k = 0; k < N_INPUTS; ++k) {
        f[INPUT_COORDINATES[k]] += p[N_PARAMETERS + k];
    }
#endif
}

static int solve_with_inputs(double t, const double *q, const double *qd, const double *p, double *qdd, double *power);

static const struct gpmegen_model FMU_MODEL = {
    N_DOF,
    N_CONSTRAINTS,
    FMU_CONSTRAINT_ORDERS,
    terms_with_inputs,
    MODEL_CONSTRAINT_TERMS,
    MODEL_BAUMGARTE_GAINS,
    MODEL_DRIVE_FORCES,
    solve_with_inputs,
    NULL,
    REDUNDANT_ROWS,
};

/* The integrators' stage: the GPME's dense solve with the inputs (the model's own recursion has
   no inputs). */
static int solve_with_inputs(double t, const double *q, const double *qd, const double *p, double *qdd, double *power)
{
    double M[N_DOF * N_DOF], f[N_DOF];
    return gpmegen_gpme_solve(&FMU_MODEL, t, q, qd, p, qdd, M, f, power);
}

static const char *status_text(int status)
{
    switch (status) {
    case GPMEGEN_SINGULAR: return "singular (the constraints' Jacobian lost rank, or the reduced mass matrix is "
                                  "not positive definite)";
    case GPMEGEN_NONFINITE: return "not finite (a state or a term is NaN or infinite)";
    case GPMEGEN_BAD_ARGUMENTS: return "invalid arguments";
    case GPMEGEN_STEP_TOO_SMALL: return "the step fell to the round-off of t";
    case GPMEGEN_NO_CONVERGENCE: return "no convergence";
    default: return "failed";
    }
}

static void say(struct fmu_instance *c, fmi2Status status, const char *category, const char *message)
{
    if (c->callbacks.logger != NULL && (c->logging || status >= fmi2Warning)) {
        c->callbacks.logger(c->callbacks.componentEnvironment, c->name, status, category, "%s", message);
    }
}

static fmi2Status failed(struct fmu_instance *c, const char *what, int status)
{
    char message[256];
    snprintf(message, sizeof message, "%s at t = %.17g: %s", what, c->t, status_text(status));
    say(c, fmi2Error, "logStatusError", message);
    return fmi2Error;
}

/* The derivatives and outputs of v's states at c->t: qdd from the GPME, the points, the
   constraints' values and lambda, the least-squares solution of D^T lambda = M qdd - f - S u
   (by its normal equations D D^T lambda = D (M qdd - f - S u)). */
static int evaluate(struct fmu_instance *c)
{
    if (c->current) {
        return c->status;
    }
    double *v = c->v, power;
    const double *q = v + VR_Q, *qd = v + VR_QD, *p = v + VR_P;
    int status = gpmegen_gpme_solve(&FMU_MODEL, c->t, q, qd, p, v + VR_DQD, c->M, c->f, &power);
    for (int i = 0; i < N_DOF; ++i) {
        v[VR_DQ + i] = qd[i];
    }
#if N_POINTS > 0
    MODEL_POINTS(q, p, v + VR_POINTS);
#endif
#if N_CONSTRAINTS > 0
    double phi_rate[N_CONSTRAINTS], D[N_CONSTRAINTS * N_DOF], gamma[N_CONSTRAINTS];
    double A[N_CONSTRAINTS * N_CONSTRAINTS], inv_d[N_CONSTRAINTS], r[N_DOF];
    MODEL_CONSTRAINT_TERMS(c->t, q, qd, p, v + VR_PHI, phi_rate, D, gamma);
    double *lambda = v + VR_LAMBDA;
    if (status == GPMEGEN_OK) {
        for (int i = 0; i < N_DOF; ++i) {
            double s = -c->f[i];
            for (int j = 0; j < N_DOF; ++j) {
                s += c->M[i * N_DOF + j] * v[VR_DQD + j];
            }
            r[i] = s;
        }
        for (int a = 0; a < N_CONSTRAINTS; ++a) {
            double s = 0.0;
            for (int j = 0; j < N_DOF; ++j) {
                s += D[a * N_DOF + j] * r[j];
            }
            lambda[a] = s;
            for (int b = 0; b < N_CONSTRAINTS; ++b) {
                double d = 0.0;
                for (int j = 0; j < N_DOF; ++j) {
                    d += D[a * N_DOF + j] * D[b * N_DOF + j];
                }
                A[a * N_CONSTRAINTS + b] = d;
            }
        }
        status = gpmegen_ldlt(N_CONSTRAINTS, A, inv_d);
        if (status == GPMEGEN_OK) {
            gpmegen_ldlt_solve(N_CONSTRAINTS, A, inv_d, lambda);
        }
    }
    if (status != GPMEGEN_OK) {
        for (int a = 0; a < N_CONSTRAINTS; ++a) {
            lambda[a] = NAN;
        }
    }
#endif
    c->status = status;
    c->current = 1;
    return status;
}

static void set_starts(struct fmu_instance *c)
{
    memset(c->v, 0, sizeof c->v);
    for (int i = 0; i < N_DOF; ++i) {
        c->v[VR_Q + i] = Q_START[i];
        c->v[VR_QD + i] = QD_START[i];
    }
    for (int k = 0; k < N_PARAMETERS; ++k) {
        c->v[VR_P + k] = P_START[k];
    }
    c->v[VR_STEP] = STEP_START;
    c->v[VR_RTOL] = RTOL_START;
    c->v[VR_ATOL] = ATOL_START;
    c->method = METHOD_START;
    c->t = 0.0;
    c->current = 0;
    c->status = GPMEGEN_OK;
    c->h_dop853 = 0.0;
}

/* ---- common to Model Exchange and Co-Simulation ------------------------------------------------ */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component component, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    (void)nCategories;
    (void)categories;
    ((struct fmu_instance *)component)->logging = loggingOn != fmi2False;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    (void)fmuResourceLocation;
    (void)visible;
    if (functions == NULL || functions->allocateMemory == NULL || functions->freeMemory == NULL) {
        return NULL;
    }
    const char *name = instanceName != NULL ? instanceName : "";
    if (fmuGUID == NULL || strcmp(fmuGUID, FMU_GUID) != 0) {
        if (functions->logger != NULL) {
            functions->logger(functions->componentEnvironment, name, fmi2Error, "logStatusError",
                              "the GUID %s is not this FMU's %s", fmuGUID != NULL ? fmuGUID : "(none)", FMU_GUID);
        }
        return NULL;
    }
    if (fmuType != fmi2ModelExchange && fmuType != fmi2CoSimulation) {
        return NULL;
    }
    struct fmu_instance *c = functions->allocateMemory(1, sizeof *c);
    if (c == NULL) {
        return NULL;
    }
    char *copy = functions->allocateMemory(strlen(name) + 1, 1);
    if (copy == NULL) {
        functions->freeMemory(c);
        return NULL;
    }
    strcpy(copy, name);
    memcpy((void *)&c->callbacks, functions, sizeof c->callbacks);
    c->name = copy;
    c->type = fmuType;
    c->logging = loggingOn != fmi2False;
    c->phase = INSTANTIATED;
    set_starts(c);
    return c;
}

void fmi2FreeInstance(fmi2Component component)
{
    struct fmu_instance *c = component;
    if (c == NULL) {
        return;
    }
    fmi2CallbackFreeMemory release = c->callbacks.freeMemory;
    release(c->name);
    release(c);
}

fmi2Status fmi2SetupExperiment(fmi2Component component, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    struct fmu_instance *c = component;
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    c->t = startTime;
    c->current = 0;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component component)
{
    ((struct fmu_instance *)component)->phase = INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component component)
{
    struct fmu_instance *c = component;
    const int status = evaluate(c);
    if (status != GPMEGEN_OK) {
        c->phase = FAILED;
        return failed(c, "the GPME at the start", status);
    }
    c->phase = STEPPING;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component component)
{
    ((struct fmu_instance *)component)->phase = TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component component)
{
    struct fmu_instance *c = component;
    set_starts(c);
    c->phase = INSTANTIATED;
    return fmi2OK;
}

static int is_output(fmi2ValueReference r)
{
    return r >= VR_DQ && r < VR_P ? 1 : r >= VR_POINTS && r < VR_STEP;
}

fmi2Status fmi2GetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    struct fmu_instance *c = component;
    int status = GPMEGEN_OK;
    for (size_t k = 0; k < nvr; ++k) {
        if (vr[k] >= N_REALS) {
            say(c, fmi2Error, "logStatusError", "fmi2GetReal: a value reference this FMU does not have");
            return fmi2Error;
        }
        if (is_output(vr[k])) {
            status = evaluate(c);
        }
        value[k] = c->v[vr[k]];
    }
    return status == GPMEGEN_OK ? fmi2OK : failed(c, "the GPME", status);
}

fmi2Status fmi2GetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    struct fmu_instance *c = component;
    for (size_t k = 0; k < nvr; ++k) {
        if (vr[k] != VR_METHOD) {
            say(c, fmi2Error, "logStatusError", "fmi2GetInteger: a value reference this FMU does not have");
            return fmi2Error;
        }
        value[k] = c->method;
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{
    (void)vr;
    (void)value;
    if (nvr > 0) {
        say(component, fmi2Error, "logStatusError", "fmi2GetBoolean: this FMU has no Boolean variables");
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    (void)value;
    (void)vr;
    if (nvr > 0) {
        say(component, fmi2Error, "logStatusError", "fmi2GetString: this FMU has no String variables");
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    struct fmu_instance *c = component;
    for (size_t k = 0; k < nvr; ++k) {
        const fmi2ValueReference r = vr[k];
        const int state = r < VR_DQ, parameter = r >= VR_P && r < VR_U, input = r >= VR_U && r < VR_POINTS;
        const int integrator = r >= VR_STEP && r < N_REALS;
        const int before = c->phase == INSTANTIATED || c->phase == INITIALIZATION;
        if (!(input || parameter || ((state || integrator) && before))) {
            say(c, fmi2Error, "logStatusError", r >= N_REALS ? "fmi2SetReal: a value reference this FMU does not have"
                : "fmi2SetReal: this variable cannot be set now (a state or the integrator's settings only before "
                  "the initialization ends; an output or derivative never)");
            return fmi2Error;
        }
        if (integrator && !(value[k] > 0.0 && isfinite(value[k]))) {
            say(c, fmi2Error, "logStatusError", "fmi2SetReal: the integrator's step, rtol and atol must be positive "
                                                "and finite");
            return fmi2Error;
        }
        c->v[r] = value[k];
    }
    c->current = 0;
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[])
{
    struct fmu_instance *c = component;
    for (size_t k = 0; k < nvr; ++k) {
        if (vr[k] != VR_METHOD || !(c->phase == INSTANTIATED || c->phase == INITIALIZATION)) {
            say(c, fmi2Error, "logStatusError", "fmi2SetInteger: only the integrator's method, before the "
                                                "initialization ends");
            return fmi2Error;
        }
        if (value[k] != METHOD_RK4 && value[k] != METHOD_DOP853) {
            say(c, fmi2Error, "logStatusError", "fmi2SetInteger: the integrator's method is 0 (rk4) or 1 (dop853)");
            return fmi2Error;
        }
        c->method = value[k];
    }
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[])
{
    (void)vr;
    (void)value;
    if (nvr > 0) {
        say(component, fmi2Error, "logStatusError", "fmi2SetBoolean: this FMU has no Boolean variables");
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[])
{
    (void)vr;
    (void)value;
    if (nvr > 0) {
        say(component, fmi2Error, "logStatusError", "fmi2SetString: this FMU has no String variables");
        return fmi2Error;
    }
    return fmi2OK;
}

static fmi2Status unsupported(fmi2Component component, const char *what)
{
    say(component, fmi2Error, "logStatusError", what);
    return fmi2Error;
}

fmi2Status fmi2GetFMUstate(fmi2Component component, fmi2FMUstate *FMUstate)
{
    (void)FMUstate;
    return unsupported(component, "fmi2GetFMUstate: not supported (canGetAndSetFMUstate is false)");
}

fmi2Status fmi2SetFMUstate(fmi2Component component, fmi2FMUstate FMUstate)
{
    (void)FMUstate;
    return unsupported(component, "fmi2SetFMUstate: not supported (canGetAndSetFMUstate is false)");
}

fmi2Status fmi2FreeFMUstate(fmi2Component component, fmi2FMUstate *FMUstate)
{
    (void)FMUstate;
    return unsupported(component, "fmi2FreeFMUstate: not supported (canGetAndSetFMUstate is false)");
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component component, fmi2FMUstate FMUstate, size_t *size)
{
    (void)FMUstate;
    (void)size;
    return unsupported(component, "fmi2SerializedFMUstateSize: not supported (canSerializeFMUstate is false)");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component component, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size)
{
    (void)FMUstate;
    (void)serializedState;
    (void)size;
    return unsupported(component, "fmi2SerializeFMUstate: not supported (canSerializeFMUstate is false)");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component component, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    (void)serializedState;
    (void)size;
    (void)FMUstate;
    return unsupported(component, "fmi2DeSerializeFMUstate: not supported (canSerializeFMUstate is false)");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component component, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[])
{
    (void)vUnknown_ref;
    (void)nUnknown;
    (void)vKnown_ref;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    return unsupported(component, "fmi2GetDirectionalDerivative: not supported (providesDirectionalDerivative is "
                                  "false)");
}

/* ---- Model Exchange ------------------------------------------------------------------------------ */

fmi2Status fmi2EnterEventMode(fmi2Component component)
{
    (void)component;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component component, fmi2EventInfo *eventInfo)
{
    (void)component;
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = fmi2False;
    eventInfo->nextEventTimeDefined = fmi2False;
    eventInfo->nextEventTime = 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component component)
{
    (void)component;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component component, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation)
{
    (void)component;
    (void)noSetFMUStatePriorToCurrentPoint;
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component component, fmi2Real time)
{
    struct fmu_instance *c = component;
    c->t = time;
    c->current = 0;
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component component, const fmi2Real x[], size_t nx)
{
    struct fmu_instance *c = component;
    if (nx != N_MOTION) {
        return unsupported(component, "fmi2SetContinuousStates: nx is not the number of states");
    }
    memcpy(c->v + VR_Q, x, N_MOTION * sizeof(double));
    c->current = 0;
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component component, fmi2Real derivatives[], size_t nx)
{
    struct fmu_instance *c = component;
    if (nx != N_MOTION) {
        return unsupported(component, "fmi2GetDerivatives: nx is not the number of states");
    }
    const int status = evaluate(c);
    memcpy(derivatives, c->v + VR_DQ, N_MOTION * sizeof(double));
    return status == GPMEGEN_OK ? fmi2OK : failed(c, "the GPME", status);
}

fmi2Status fmi2GetEventIndicators(fmi2Component component, fmi2Real eventIndicators[], size_t ni)
{
    (void)eventIndicators;
    return ni == 0 ? fmi2OK : unsupported(component, "fmi2GetEventIndicators: this FMU has no event indicators");
}

fmi2Status fmi2GetContinuousStates(fmi2Component component, fmi2Real x[], size_t nx)
{
    struct fmu_instance *c = component;
    if (nx != N_MOTION) {
        return unsupported(component, "fmi2GetContinuousStates: nx is not the number of states");
    }
    memcpy(x, c->v + VR_Q, N_MOTION * sizeof(double));
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component component, fmi2Real x_nominal[], size_t nx)
{
    (void)component;
    for (size_t i = 0; i < nx; ++i) {
        x_nominal[i] = 1.0;
    }
    return fmi2OK;
}

/* ---- Co-Simulation ------------------------------------------------------------------------------- */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr;
    (void)order;
    (void)value;
    return nvr == 0 ? fmi2OK : unsupported(component, "fmi2SetRealInputDerivatives: not supported "
                                                      "(canInterpolateInputs is false)");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    (void)vr;
    (void)order;
    (void)value;
    return nvr == 0 ? fmi2OK : unsupported(component, "fmi2GetRealOutputDerivatives: not supported "
                                                      "(maxOutputDerivativeOrder is 0)");
}

/* Whole steps of dt over h, and one shorter last step where h is not a whole number of them (the
   grid of gpmegen.runtime.integrators.loop.grid). */
static long steps_over(double h, double dt)
{
    const double steps = h / dt;
    long n = lround(steps);
    if (fabs(steps - (double)n) > STEP_ROUND_OFF) {
        n = (long)ceil(steps);
    }
    return n > 1 ? n : 1;
}

fmi2Status fmi2DoStep(fmi2Component component, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    struct fmu_instance *c = component;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (c->phase != STEPPING) {
        return unsupported(component, "fmi2DoStep: not in the step mode (after fmi2ExitInitializationMode, "
                                      "without an earlier failure)");
    }
    if (!(communicationStepSize > 0.0) || !isfinite(communicationStepSize)) {
        return unsupported(component, "fmi2DoStep: the communication step must be positive and finite");
    }
    const double t0 = currentCommunicationPoint, t1 = t0 + communicationStepSize;
    double *v = c->v;
    const double *p = v + VR_P;
    int status;
    if (c->method == METHOD_RK4) {
        const long n = steps_over(communicationStepSize, v[VR_STEP]);
        /* saving every n-th step: the start and the end (3 rows, the bound gpmegen_rk4 documents) */
        double t_out[3], q_out[3 * N_DOF], qd_out[3 * N_DOF], w_out[6], w0[2] = {0.0, 0.0};
        long saved = 0;
        status = gpmegen_rk4(&FMU_MODEL, t0, v[VR_STEP], n, t1, 0, n, n, v + VR_Q, v + VR_QD, w0, p, t_out, q_out,
                             qd_out, w_out, &saved);
        if (status == GPMEGEN_OK) {
            memcpy(v + VR_Q, q_out + (saved - 1) * N_DOF, N_DOF * sizeof(double));
            memcpy(v + VR_QD, qd_out + (saved - 1) * N_DOF, N_DOF * sizeof(double));
        }
    } else {
        double y[N_Y], y_out[N_Y];
        long saved, counts[5] = {0, 0, 0, 0, 0};
        memcpy(y, v + VR_Q, N_MOTION * sizeof(double));
        y[N_MOTION] = y[N_MOTION + 1] = 0.0;
        status = gpmegen_dop853(&FMU_MODEL, t0, y, 1, &t1, v[VR_RTOL], v[VR_ATOL], &c->h_dop853, 0, NULL, p, y_out,
                                &saved, counts);
        if (status == GPMEGEN_OK) {
            memcpy(v + VR_Q, y_out, N_MOTION * sizeof(double));
        }
    }
    if (status != GPMEGEN_OK) {
        c->phase = FAILED;
        return failed(c, c->method == METHOD_RK4 ? "RK4" : "DOP853", status);
    }
    c->t = t1;
    c->current = 0;
    status = evaluate(c);
    if (status != GPMEGEN_OK) {
        c->phase = FAILED;
        return failed(c, "the GPME at the step's end", status);
    }
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component component)
{
    (void)component;
    return fmi2OK;
}

fmi2Status fmi2GetStatus(fmi2Component component, const fmi2StatusKind s, fmi2Status *value)
{
    (void)s;
    *value = ((struct fmu_instance *)component)->phase == FAILED ? fmi2Error : fmi2OK;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component component, const fmi2StatusKind s, fmi2Real *value)
{
    if (s != fmi2LastSuccessfulTime) {
        return fmi2Discard;
    }
    *value = ((struct fmu_instance *)component)->t;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component component, const fmi2StatusKind s, fmi2Integer *value)
{
    (void)component;
    (void)s;
    (void)value;
    return fmi2Discard;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component component, const fmi2StatusKind s, fmi2Boolean *value)
{
    if (s != fmi2Terminated) {
        return fmi2Discard;
    }
    *value = fmi2False;
    (void)component;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component component, const fmi2StatusKind s, fmi2String *value)
{
    (void)component;
    (void)s;
    (void)value;
    return fmi2Discard;
}
