/*
 * gw_fmi3_absent.c -- the FMI 3.0 functions of what this FMU does not have: no structural
 * parameters (no Configuration Mode), no clocks (so no clocked partitions for Scheduled
 * Execution and no discrete states to evaluate outside Event Mode), no per-element dependency
 * information (modelDescription.xml's <ModelStructure> lists the dependencies).  The capability
 * flags of modelDescription.xml say so (providesEvaluateDiscreteStates,
 * providesPerElementDependencies = false); a call anyway fails with fmi3Error and its reason,
 * in any state and interface, and the instance enters the Error state (the frame, gw_fmi3.h).
 * fmi3GetClock and fmi3SetClock answer an empty list with fmi3OK, as every typed getter and
 * setter of the layer does.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu3.c */
#else

#include "gw_fmi3.h"

/* every function here: any interface, any state (the reason is what the call gets) */
#define GW3_IFACE_EnterConfigurationMode GW3_IFACE_ANY
#define GW3_MASK_EnterConfigurationMode GW3_MASK_NotSupported
#define GW3_IFACE_ExitConfigurationMode GW3_IFACE_ANY
#define GW3_MASK_ExitConfigurationMode GW3_MASK_NotSupported
#define GW3_IFACE_GetClock GW3_IFACE_ANY
#define GW3_MASK_GetClock GW3_MASK_NotSupported
#define GW3_IFACE_SetClock GW3_IFACE_ANY
#define GW3_MASK_SetClock GW3_MASK_NotSupported
#define GW3_IFACE_GetIntervalDecimal GW3_IFACE_ANY
#define GW3_MASK_GetIntervalDecimal GW3_MASK_NotSupported
#define GW3_IFACE_GetIntervalFraction GW3_IFACE_ANY
#define GW3_MASK_GetIntervalFraction GW3_MASK_NotSupported
#define GW3_IFACE_GetShiftDecimal GW3_IFACE_ANY
#define GW3_MASK_GetShiftDecimal GW3_MASK_NotSupported
#define GW3_IFACE_GetShiftFraction GW3_IFACE_ANY
#define GW3_MASK_GetShiftFraction GW3_MASK_NotSupported
#define GW3_IFACE_SetIntervalDecimal GW3_IFACE_ANY
#define GW3_MASK_SetIntervalDecimal GW3_MASK_NotSupported
#define GW3_IFACE_SetIntervalFraction GW3_IFACE_ANY
#define GW3_MASK_SetIntervalFraction GW3_MASK_NotSupported
#define GW3_IFACE_SetShiftDecimal GW3_IFACE_ANY
#define GW3_MASK_SetShiftDecimal GW3_MASK_NotSupported
#define GW3_IFACE_SetShiftFraction GW3_IFACE_ANY
#define GW3_MASK_SetShiftFraction GW3_MASK_NotSupported
#define GW3_IFACE_EvaluateDiscreteStates GW3_IFACE_ANY
#define GW3_MASK_EvaluateDiscreteStates GW3_MASK_NotSupported
#define GW3_IFACE_ActivateModelPartition GW3_IFACE_ANY
#define GW3_MASK_ActivateModelPartition GW3_MASK_NotSupported
#define GW3_IFACE_GetNumberOfVariableDependencies GW3_IFACE_ANY
#define GW3_MASK_GetNumberOfVariableDependencies GW3_MASK_NotSupported
#define GW3_IFACE_GetVariableDependencies GW3_IFACE_ANY
#define GW3_MASK_GetVariableDependencies GW3_MASK_NotSupported

/* the whole body of fmi3<name>: the frame, then fmi3Error with the reason */
#define GW3_ABSENT(name, reason)                                                                \
    GW3_FRAME(name);                                                                            \
    GW3_FAIL("%s: %s", fn, reason);                                                             \
    GW3_FRAME_END()

#define GW3_NO_CONFIGURATION                                                                    \
    "this FMU has no Configuration Mode (no structural parameters in modelDescription.xml)"
#define GW3_NO_CLOCKS "this FMU has no clocks (no Clock variables in modelDescription.xml)"
#define GW3_NO_DEPENDENCIES                                                                     \
    "not provided by this FMU (providesPerElementDependencies=false): see <ModelStructure> of "   \
    "modelDescription.xml"

/* ---- Configuration Mode (FMI 3.0.2 section 2.3.6) ----------------------------------------- */
fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    GW3_ABSENT(EnterConfigurationMode, GW3_NO_CONFIGURATION);
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    GW3_ABSENT(ExitConfigurationMode, GW3_NO_CONFIGURATION);
}

/* ---- clocks (section 2.2.8) ---------------------------------------------------------------- */
/* the value references of fmi3GetClock / fmi3SetClock: none is a clock, an empty list is
 * fmi3OK (as for every typed getter and setter); else fmi3Error, the reason logged */
static fmi3Status gw_fmi3_clock_refs(gw_instance *I, const char *fn, const fmi3ValueReference vr[],
                                     size_t n) {
    const gw_variable *v = n > 0 && vr ? gw_variable_find(I->m, vr[0]) : NULL;
    if (n == 0) return fmi3OK;
    if (!vr)
        GW_LOG_ERR(I, "%s: NULL array for %lu value references", fn, (unsigned long)n);
    else if (v)
        GW_LOG_ERR(I, "%s: value reference %u (%s) is not a Clock: %s", fn, vr[0], v->name,
                   GW3_NO_CLOCKS);
    else if (vr[0] == 0)
        GW_LOG_ERR(I, "%s: value reference 0 (time) is not a Clock: %s", fn, GW3_NO_CLOCKS);
    else if (gw_fmi3_array_find(I->m, vr[0]))
        GW_LOG_ERR(I, "%s: value reference %u (%s) is not a Clock: %s", fn, vr[0],
                   gw_fmi3_array_find(I->m, vr[0])->name, GW3_NO_CLOCKS);
    else
        GW_LOG_ERR(I, "%s: unknown value reference %u: %s", fn, vr[0], GW3_NO_CLOCKS);
    return fmi3Error;
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Clock values[]) {
    GW3_FRAME(GetClock);
    (void)values;
    status = gw_fmi3_clock_refs(I, fn, valueReferences, nValueReferences);
    GW3_FRAME_END();
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, const fmi3Clock values[]) {
    GW3_FRAME(SetClock);
    (void)values;
    status = gw_fmi3_clock_refs(I, fn, valueReferences, nValueReferences);
    GW3_FRAME_END();
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance,
                                  const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences, (void)nValueReferences, (void)intervals, (void)qualifiers;
    GW3_ABSENT(GetIntervalDecimal, GW3_NO_CLOCKS);
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance,
                                   const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[],
                                   fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions,
        (void)qualifiers;
    GW3_ABSENT(GetIntervalFraction, GW3_NO_CLOCKS);
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[]) {
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    GW3_ABSENT(GetShiftDecimal, GW3_NO_CLOCKS);
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[],
                                fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    GW3_ABSENT(GetShiftFraction, GW3_NO_CLOCKS);
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance,
                                  const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[]) {
    (void)valueReferences, (void)nValueReferences, (void)intervals;
    GW3_ABSENT(SetIntervalDecimal, GW3_NO_CLOCKS);
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance,
                                   const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    GW3_ABSENT(SetIntervalFraction, GW3_NO_CLOCKS);
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[]) {
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    GW3_ABSENT(SetShiftDecimal, GW3_NO_CLOCKS);
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[],
                                const fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    GW3_ABSENT(SetShiftFraction, GW3_NO_CLOCKS);
}

/* discrete states are updated in Event Mode only (fmi3UpdateDiscreteStates) */
fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    GW3_ABSENT(EvaluateDiscreteStates,
               "not provided by this FMU (providesEvaluateDiscreteStates=false): it has no "
               "clocks; discrete states change in Event Mode (fmi3UpdateDiscreteStates)");
}

/* ---- Scheduled Execution (chapter 5) ------------------------------------------------------- */
fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference, (void)activationTime;
    GW3_ABSENT(ActivateModelPartition,
               "Scheduled Execution is not supported by this FMU (no <ScheduledExecution> in "
               "modelDescription.xml; it has no clocks and no model partitions)");
}

/* ---- dependencies (section 2.2.9) ----------------------------------------------------------- */
fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance,
                                               fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    (void)valueReference, (void)nDependencies;
    GW3_ABSENT(GetNumberOfVariableDependencies, GW3_NO_DEPENDENCIES);
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[],
                                       fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[],
                                       fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    (void)dependent, (void)elementIndicesOfDependent, (void)independents,
        (void)elementIndicesOfIndependents, (void)dependencyKinds, (void)nDependencies;
    GW3_ABSENT(GetVariableDependencies, GW3_NO_DEPENDENCIES);
}

#endif /* GW_UNITY_BUILD */
