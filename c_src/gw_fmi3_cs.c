/*
 * gw_fmi3_cs.c -- part of the FMI 3.0 layer (gw_fmi3.h).
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu3.c */
#else

#include "gw_fmi3.h"

#endif /* GW_UNITY_BUILD */
