"""The Taylor-series method generated from the model's expression graph, and the ensemble path.

    graph      the ode's CasADi algorithm -> a decomposition into elementary operations
    rewrite    cheaper decompositions, exact in real arithmetic
    kernel_c   the decomposition -> the C of the Taylor kernel (one lane or W lanes), from
               kernel_plan (its nodes and terms), kernel_recurrences (the C statements) and
               kernel_packs (the one-lane kernel's packed interior sums)
    events     the event indicators evaluated from the same Taylor coefficients
    ensemble   many trajectories of one FMU's model at once (Ensemble)

docs/taylor.md describes the method; the runtime's side is c_src/gw_taylor*.c, gw_ensemble*.
"""
