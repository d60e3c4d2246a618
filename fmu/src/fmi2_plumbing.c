/* FMI 2.0 co-simulation plumbing for BowdenPlant: instance life cycle, variable access by value
 * reference through the generated table, FMU state save/restore and serialisation, logging.
 * Every log message is passed as format "%s" plus one preformatted string, so that a logger
 * written in a language without varargs (ctypes) can read it as a sixth argument.
 * Nothing here is model specific beyond the contract of bowden_physics.h. Every fmi2 function
 * is exported (tools such as fmpy resolve all of them when loading); those that do not apply to
 * a co-simulation FMU return fmi2Error with a log message.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#include "bowden_physics.h"

typedef enum {
    STATE_INSTANTIATED,
    STATE_INITIALIZATION,
    STATE_STEP,
    STATE_TERMINATED,
    STATE_ERROR
} InstanceState;

typedef struct {
    BowdenModel model;
    char instance_name[128];
    fmi2CallbackFunctions cb;
    fmi2Boolean logging_on;
    InstanceState state;
    double start_time_s;
} Instance;

static const BowdenVarInfo VARS[BOWDEN_N_VARS] = BOWDEN_VAR_TABLE(BowdenModel);

/* Magic of a serialised state: "BOWD" and the layout size, so stale bytes are refused. */
#define STATE_MAGIC 0x424F5744u

static void log_msg(const Instance *inst, fmi2Status status, const char *category,
                    const char *fmt, ...)
{
    char buf[512];
    va_list ap;
    if (inst == NULL || inst->cb.logger == NULL) {
        return;
    }
    if (status == fmi2OK && !inst->logging_on) {
        return;
    }
    va_start(ap, fmt);
    vsnprintf(buf, sizeof(buf), fmt, ap);
    va_end(ap);
    inst->cb.logger(inst->cb.componentEnvironment, inst->instance_name, status, category, "%s",
                    buf);
}

#define LOG_ERROR(inst, ...) log_msg((inst), fmi2Error, "logStatusError", __VA_ARGS__)

static fmi2Status not_supported(fmi2Component c, const char *func)
{
    LOG_ERROR((Instance *)c, "%s is not supported by this co-simulation FMU", func);
    return fmi2Error;
}

/* ---- inquiry, logging ------------------------------------------------------------------- */

const char *fmi2GetTypesPlatform(void)
{
    return fmi2TypesPlatform;
}

const char *fmi2GetVersion(void)
{
    return fmi2Version;
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    (void)nCategories;
    (void)categories;
    if (c == NULL) {
        return fmi2Error;
    }
    ((Instance *)c)->logging_on = loggingOn;
    return fmi2OK;
}

/* ---- life cycle ------------------------------------------------------------------------- */

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn)
{
    Instance *inst;
    (void)fmuResourceLocation;
    (void)visible;
    if (functions == NULL || instanceName == NULL) {
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        if (functions->logger) {
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error,
                              "logStatusError", "%s",
                              "fmuType must be fmi2CoSimulation (BowdenPlant is CS only)");
        }
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, BOWDEN_GUID) != 0) {
        if (functions->logger) {
            char msg[200];
            snprintf(msg, sizeof(msg), "fmuGUID %.60s does not match this binary's %s",
                     fmuGUID ? fmuGUID : "(null)", BOWDEN_GUID);
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error,
                              "logStatusError", "%s", msg);
        }
        return NULL;
    }
    /* calloc, not the environment's allocator: canNotUseMemoryManagementFunctions = true */
    inst = (Instance *)calloc(1, sizeof(Instance));
    if (inst == NULL) {
        return NULL;
    }
    strncpy(inst->instance_name, instanceName, sizeof(inst->instance_name) - 1);
    inst->cb = *functions;
    inst->logging_on = loggingOn;
    inst->state = STATE_INSTANTIATED;
    bowden_model_defaults(&inst->model);
    return inst;
}

void fmi2FreeInstance(fmi2Component c)
{
    free(c);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    Instance *inst = (Instance *)c;
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    if (inst == NULL) {
        return fmi2Error;
    }
    if (inst->state != STATE_INSTANTIATED) {
        LOG_ERROR(inst, "fmi2SetupExperiment is only allowed after fmi2Instantiate");
        return fmi2Error;
    }
    if (!isfinite(startTime)) {
        LOG_ERROR(inst, "startTime = %g must be finite", startTime);
        return fmi2Error;
    }
    inst->start_time_s = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    Instance *inst = (Instance *)c;
    if (inst == NULL) {
        return fmi2Error;
    }
    if (inst->state != STATE_INSTANTIATED) {
        LOG_ERROR(inst, "fmi2EnterInitializationMode is only allowed after fmi2Instantiate");
        return fmi2Error;
    }
    inst->state = STATE_INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    Instance *inst = (Instance *)c;
    char msg[400];
    if (inst == NULL) {
        return fmi2Error;
    }
    if (inst->state != STATE_INITIALIZATION) {
        LOG_ERROR(inst, "fmi2ExitInitializationMode is only allowed in initialization mode");
        return fmi2Error;
    }
    if (bowden_model_init(&inst->model, inst->start_time_s, msg, sizeof(msg))) {
        LOG_ERROR(inst, "%s", msg);
        return fmi2Error; /* stays in initialization mode: the caller may fix inputs */
    }
    inst->state = STATE_STEP;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    Instance *inst = (Instance *)c;
    if (inst == NULL) {
        return fmi2Error;
    }
    inst->state = STATE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    Instance *inst = (Instance *)c;
    if (inst == NULL) {
        return fmi2Error;
    }
    bowden_model_defaults(&inst->model);
    inst->start_time_s = 0.0;
    inst->state = STATE_INSTANTIATED;
    return fmi2OK;
}

/* ---- variable access -------------------------------------------------------------------- */

static const char *kind_name(BowdenVarKind k)
{
    return k == BOWDEN_REAL ? "Real" : (k == BOWDEN_INTEGER ? "Integer" : "Boolean");
}

static const BowdenVarInfo *lookup(Instance *inst, fmi2ValueReference vr, BowdenVarKind kind)
{
    if (vr >= BOWDEN_N_VARS) {
        LOG_ERROR(inst, "value reference %u does not exist (0 .. %d)", (unsigned)vr,
                  BOWDEN_N_VARS - 1);
        return NULL;
    }
    if (VARS[vr].kind != kind) {
        LOG_ERROR(inst, "variable %s (value reference %u) is %s, not %s", VARS[vr].name,
                  (unsigned)vr, kind_name(VARS[vr].kind), kind_name(kind));
        return NULL;
    }
    return &VARS[vr];
}

/* May `info` be set now? Parameters are fixed: before the end of initialization only. */
static int settable(Instance *inst, const BowdenVarInfo *info)
{
    if (info->causality == BOWDEN_OUTPUT) {
        LOG_ERROR(inst, "variable %s is an output and cannot be set", info->name);
        return 0;
    }
    if (info->causality == BOWDEN_PARAMETER && inst->state != STATE_INSTANTIATED &&
        inst->state != STATE_INITIALIZATION) {
        LOG_ERROR(inst,
                  "parameter %s is fixed: set it before fmi2ExitInitializationMode "
                  "(or after fmi2Reset)",
                  info->name);
        return 0;
    }
    if (inst->state == STATE_TERMINATED || inst->state == STATE_ERROR) {
        LOG_ERROR(inst, "variable %s cannot be set after fmi2Terminate", info->name);
        return 0;
    }
    return 1;
}

static int in_range(Instance *inst, const BowdenVarInfo *info, double v)
{
    if (!isfinite(v)) {
        LOG_ERROR(inst, "%s = %g is not a finite number; allowed range is [%g, %g]", info->name, v,
                  info->lo, info->hi);
        return 0;
    }
    if (info->has_range && (v < info->lo || v > info->hi)) {
        LOG_ERROR(inst, "%s = %g is out of range; allowed range is [%g, %g]", info->name, v,
                  info->lo, info->hi);
        return 0;
    }
    return 1;
}

#define FIELD(inst, info, type) ((type *)((char *)&(inst)->model + (info)->offset))

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[])
{
    Instance *inst = (Instance *)c;
    size_t i;
    if (inst == NULL || (nvr > 0 && (vr == NULL || value == NULL))) {
        return fmi2Error;
    }
    for (i = 0; i < nvr; i++) {
        const BowdenVarInfo *info = lookup(inst, vr[i], BOWDEN_REAL);
        if (info == NULL) {
            return fmi2Error;
        }
        value[i] = *FIELD(inst, info, double);
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[])
{
    Instance *inst = (Instance *)c;
    size_t i;
    if (inst == NULL || (nvr > 0 && (vr == NULL || value == NULL))) {
        return fmi2Error;
    }
    for (i = 0; i < nvr; i++) {
        const BowdenVarInfo *info = lookup(inst, vr[i], BOWDEN_INTEGER);
        if (info == NULL) {
            return fmi2Error;
        }
        value[i] = *FIELD(inst, info, int);
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[])
{
    Instance *inst = (Instance *)c;
    size_t i;
    if (inst == NULL || (nvr > 0 && (vr == NULL || value == NULL))) {
        return fmi2Error;
    }
    for (i = 0; i < nvr; i++) {
        const BowdenVarInfo *info = lookup(inst, vr[i], BOWDEN_BOOLEAN);
        if (info == NULL) {
            return fmi2Error;
        }
        value[i] = *FIELD(inst, info, int) ? fmi2True : fmi2False;
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[])
{
    (void)vr;
    (void)value;
    if (nvr == 0) {
        return fmi2OK;
    }
    LOG_ERROR((Instance *)c, "BowdenPlant has no String variables");
    return fmi2Error;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[])
{
    Instance *inst = (Instance *)c;
    size_t i;
    if (inst == NULL || (nvr > 0 && (vr == NULL || value == NULL))) {
        return fmi2Error;
    }
    for (i = 0; i < nvr; i++) {
        const BowdenVarInfo *info = lookup(inst, vr[i], BOWDEN_REAL);
        if (info == NULL || !settable(inst, info) || !in_range(inst, info, value[i])) {
            return fmi2Error;
        }
        *FIELD(inst, info, double) = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[])
{
    Instance *inst = (Instance *)c;
    size_t i;
    if (inst == NULL || (nvr > 0 && (vr == NULL || value == NULL))) {
        return fmi2Error;
    }
    for (i = 0; i < nvr; i++) {
        const BowdenVarInfo *info = lookup(inst, vr[i], BOWDEN_INTEGER);
        if (info == NULL || !settable(inst, info) || !in_range(inst, info, (double)value[i])) {
            return fmi2Error;
        }
        *FIELD(inst, info, int) = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[])
{
    Instance *inst = (Instance *)c;
    size_t i;
    if (inst == NULL || (nvr > 0 && (vr == NULL || value == NULL))) {
        return fmi2Error;
    }
    for (i = 0; i < nvr; i++) {
        const BowdenVarInfo *info = lookup(inst, vr[i], BOWDEN_BOOLEAN);
        if (info == NULL || !settable(inst, info)) {
            return fmi2Error;
        }
        *FIELD(inst, info, int) = value[i] ? 1 : 0;
    }
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[])
{
    (void)vr;
    (void)value;
    if (nvr == 0) {
        return fmi2OK;
    }
    LOG_ERROR((Instance *)c, "BowdenPlant has no String variables");
    return fmi2Error;
}

/* ---- FMU state: a copy of the instance (plain data, no pointers inside the model) -------- */

typedef struct {
    unsigned magic;
    unsigned size;
    InstanceState state;
    double start_time_s;
    BowdenModel model;
} SavedState;

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    Instance *inst = (Instance *)c;
    SavedState *s;
    if (inst == NULL || FMUstate == NULL) {
        return fmi2Error;
    }
    s = (SavedState *)*FMUstate;
    if (s == NULL) {
        s = (SavedState *)malloc(sizeof(SavedState));
        if (s == NULL) {
            LOG_ERROR(inst, "out of memory saving the FMU state");
            return fmi2Error;
        }
    }
    s->magic = STATE_MAGIC;
    s->size = (unsigned)sizeof(SavedState);
    s->state = inst->state;
    s->start_time_s = inst->start_time_s;
    s->model = inst->model;
    *FMUstate = s;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    Instance *inst = (Instance *)c;
    const SavedState *s = (const SavedState *)FMUstate;
    if (inst == NULL) {
        return fmi2Error;
    }
    if (s == NULL || s->magic != STATE_MAGIC || s->size != sizeof(SavedState)) {
        LOG_ERROR(inst, "FMUstate is not a state saved by this BowdenPlant binary");
        return fmi2Error;
    }
    inst->state = s->state;
    inst->start_time_s = s->start_time_s;
    inst->model = s->model;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    (void)c;
    if (FMUstate != NULL) {
        free(*FMUstate);
        *FMUstate = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    (void)c;
    (void)FMUstate;
    if (size == NULL) {
        return fmi2Error;
    }
    *size = sizeof(SavedState);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate,
                                 fmi2Byte serializedState[], size_t size)
{
    Instance *inst = (Instance *)c;
    if (FMUstate == NULL || serializedState == NULL || size != sizeof(SavedState)) {
        LOG_ERROR(inst, "serialisation needs a saved FMUstate and a buffer of %u bytes",
                  (unsigned)sizeof(SavedState));
        return fmi2Error;
    }
    memcpy(serializedState, FMUstate, sizeof(SavedState));
    return fmi2OK;
}

/* A deserialised state: instance state, every parameter and input of the variable table within
   its range (as the setters require), then the model's own state (bowden_model_check_state). */
static int saved_state_valid(Instance *inst, const SavedState *s)
{
    char msg[300];
    size_t vr;
    if (s->state < STATE_INSTANTIATED || s->state > STATE_ERROR) {
        LOG_ERROR(inst, "serialised state rejected: instance state %d is not one of 0 .. %d",
                  (int)s->state, (int)STATE_ERROR);
        return 0;
    }
    if (!isfinite(s->start_time_s)) {
        LOG_ERROR(inst, "serialised state rejected: start time %g is not finite",
                  s->start_time_s);
        return 0;
    }
    for (vr = 0; vr < BOWDEN_N_VARS; vr++) {
        const BowdenVarInfo *info = &VARS[vr];
        const char *field = (const char *)&s->model + info->offset;
        double v;
        if (info->causality == BOWDEN_OUTPUT) {
            continue; /* checked with the model's state */
        }
        if (info->kind == BOWDEN_REAL) {
            memcpy(&v, field, sizeof(v));
        } else {
            int iv;
            memcpy(&iv, field, sizeof(iv));
            v = (double)iv;
            if (info->kind == BOWDEN_BOOLEAN && iv != 0 && iv != 1) {
                LOG_ERROR(inst, "serialised state rejected: %s = %d is not a Boolean",
                          info->name, iv);
                return 0;
            }
        }
        if (!isfinite(v) || (info->has_range && (v < info->lo || v > info->hi))) {
            LOG_ERROR(inst, "serialised state rejected: %s = %g; allowed range is [%g, %g]",
                      info->name, v, info->lo, info->hi);
            return 0;
        }
    }
    if (bowden_model_check_state(&s->model, msg, sizeof(msg))) {
        LOG_ERROR(inst, "serialised state rejected: %s", msg);
        return 0;
    }
    return 1;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    Instance *inst = (Instance *)c;
    SavedState *s;
    if (serializedState == NULL || FMUstate == NULL || size != sizeof(SavedState)) {
        LOG_ERROR(inst, "a serialised BowdenPlant state has %u bytes, got %u",
                  (unsigned)sizeof(SavedState), (unsigned)size);
        return fmi2Error;
    }
    s = (SavedState *)malloc(sizeof(SavedState));
    if (s == NULL) {
        return fmi2Error;
    }
    memcpy(s, serializedState, sizeof(SavedState));
    if (s->magic != STATE_MAGIC || s->size != sizeof(SavedState)) {
        free(s);
        LOG_ERROR(inst, "the bytes are not a state serialised by this BowdenPlant binary");
        return fmi2Error;
    }
    /* The bytes come from outside (a file, another process): a state with a NaN, a negative
       tension or a parameter out of its range would make every later step wrong or worse. */
    if (!saved_state_valid(inst, s)) {
        free(s);
        return fmi2Error;
    }
    free(*FMUstate);
    *FMUstate = s;
    return fmi2OK;
}

/* ---- co-simulation ---------------------------------------------------------------------- */

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    Instance *inst = (Instance *)c;
    char msg[400];
    (void)currentCommunicationPoint; /* the FMU keeps its own time (inputs are held per step) */
    (void)noSetFMUStatePriorToCurrentPoint;
    if (inst == NULL) {
        return fmi2Error;
    }
    if (inst->state != STATE_STEP) {
        LOG_ERROR(inst, "fmi2DoStep is only allowed after fmi2ExitInitializationMode");
        return fmi2Error;
    }
    if (bowden_model_step(&inst->model, communicationStepSize, msg, sizeof(msg))) {
        LOG_ERROR(inst, "%s", msg);
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    return not_supported(c, "fmi2CancelStep (doStep never runs asynchronously)");
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    (void)s;
    (void)value;
    return not_supported(c, "fmi2GetStatus");
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    Instance *inst = (Instance *)c;
    if (inst != NULL && value != NULL && s == fmi2LastSuccessfulTime) {
        *value = inst->model.time_s;
        return fmi2OK;
    }
    return not_supported(c, "fmi2GetRealStatus (other than fmi2LastSuccessfulTime)");
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    (void)s;
    (void)value;
    return not_supported(c, "fmi2GetIntegerStatus");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    (void)s;
    (void)value;
    return not_supported(c, "fmi2GetBooleanStatus");
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    (void)s;
    (void)value;
    return not_supported(c, "fmi2GetStringStatus");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return not_supported(c, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[], fmi2Real value[])
{
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return not_supported(c, "fmi2GetRealOutputDerivatives");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[])
{
    (void)vUnknown_ref;
    (void)nUnknown;
    (void)vKnown_ref;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    return not_supported(c, "fmi2GetDirectionalDerivative");
}

/* ---- model exchange: not provided (co-simulation only) ---------------------------------- */

fmi2Status fmi2EnterEventMode(fmi2Component c)
{
    return not_supported(c, "fmi2EnterEventMode (model exchange)");
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo)
{
    (void)eventInfo;
    return not_supported(c, "fmi2NewDiscreteStates (model exchange)");
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c)
{
    return not_supported(c, "fmi2EnterContinuousTimeMode (model exchange)");
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c,
                                       fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    (void)enterEventMode;
    (void)terminateSimulation;
    return not_supported(c, "fmi2CompletedIntegratorStep (model exchange)");
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time)
{
    (void)time;
    return not_supported(c, "fmi2SetTime (model exchange)");
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx)
{
    (void)x;
    (void)nx;
    return not_supported(c, "fmi2SetContinuousStates (model exchange)");
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx)
{
    (void)derivatives;
    (void)nx;
    return not_supported(c, "fmi2GetDerivatives (model exchange)");
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    (void)eventIndicators;
    (void)ni;
    return not_supported(c, "fmi2GetEventIndicators (model exchange)");
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx)
{
    (void)x;
    (void)nx;
    return not_supported(c, "fmi2GetContinuousStates (model exchange)");
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx)
{
    (void)x_nominal;
    (void)nx;
    return not_supported(c, "fmi2GetNominalsOfContinuousStates (model exchange)");
}
