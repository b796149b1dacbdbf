/*
 * gw_state_blob.c -- an FMU state as the FMI layers hand it out, shared by the FMI 2.0 and
 * FMI 3.0 layers (gw_fmi2_state.c, gw_fmi3_state.c): one blob holding the core's serialised
 * state (gw_state.c, layout there) with the front end's two ints, so that get/set and
 * (de)serialise share one code path.  The layers give meaning to the two ints and check them
 * (gw_blob_check's check_front); everything else is here.  Each function takes the calling
 * fmi function's name (fn, the start of every message).  Included by the unity files
 * (gw_fmu.c, gw_fmu3.c) after the core.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <string.h>

#include "gw_instance.h"

typedef struct {
    size_t size;
    unsigned char data[]; /* size bytes */
} gw_blob;

/* A front end's check of the two ints of a state the core accepted: 1 and *facts filled in
 * (what the ints say about the state, for gw_state_check_run), or 0 with the reason logged. */
typedef int (*gw_blob_front_check)(void *front_end, const char *fn, const int front[2],
                                   gw_state_facts *facts);

/* 1 if the core accepts buf as a state of this model (layout, checksum, ranges), the front
 * end accepts its two ints, and the fields agree with each other and with the live path's
 * checks (gw_state_check_run); else 0, the reason logged.  Run before applying it. */
GW_INTERNAL int gw_blob_check(gw_instance *I, const char *fn, const unsigned char *buf,
                              size_t size, gw_blob_front_check check_front, void *front_end) {
    gw_state_facts facts;
    int front[2];
    if (!gw_state_check(I, fn, buf, size)) return 0;
    gw_state_front(I, buf, front);
    memset(&facts, 0, sizeof(facts));
    if (!check_front(front_end, fn, front, &facts)) return 0;
    return gw_state_check_run(I, fn, buf, &facts);
}

/* The blob *slot if it has the right size, else a new one (the old one freed). NULL: out of
 * memory, logged. */
static gw_blob *gw_blob_sized(gw_instance *I, const char *fn, void **slot, size_t size) {
    gw_blob *b = (gw_blob *)*slot;
    if (b && b->size != size) {
        gw_free(I, b);
        b = NULL;
        *slot = NULL;
    }
    if (!b) {
        b = (gw_blob *)gw_alloc(I, 1, sizeof(gw_blob) + size);
        if (b) b->size = size;
    }
    if (!b) GW_LOG_ERR(I, "%s: out of memory", fn);
    return b;
}

/* the instance's state with the front end's two ints into *slot (reused if it fits) */
GW_INTERNAL gw_status gw_blob_take(gw_instance *I, const char *fn, void **slot,
                                   const int front[2]) {
    gw_blob *b = gw_blob_sized(I, fn, slot, gw_state_size(I));
    if (!b) return GW_ERROR;
    gw_state_write(I, front, b->data);
    *slot = b;
    return GW_OK;
}

/* serialised bytes that gw_blob_check accepted into *slot (reused if it fits) */
GW_INTERNAL gw_status gw_blob_load(gw_instance *I, const char *fn, const unsigned char *buf,
                                   size_t size, void **slot) {
    gw_blob *b = gw_blob_sized(I, fn, slot, size);
    if (!b) return GW_ERROR;
    memcpy(b->data, buf, size);
    *slot = b;
    return GW_OK;
}

/* the blob's bytes into buf of size bytes (at least the blob's size) */
GW_INTERNAL gw_status gw_blob_serialize(gw_instance *I, const char *fn, const gw_blob *b,
                                        unsigned char *buf, size_t size) {
    if (size < b->size)
        GW_LOG_ERR(I, "%s: buffer of %lu bytes, %lu needed", fn, (unsigned long)size,
                   (unsigned long)b->size);
    else
        memcpy(buf, b->data, b->size);
    return size < b->size ? GW_ERROR : GW_OK;
}

GW_INTERNAL void gw_blob_free(gw_instance *I, void **slot) {
    if (slot && *slot) {
        gw_free(I, *slot);
        *slot = NULL;
    }
}

#endif /* GW_UNITY_BUILD */
