/*
 * capi_figures.c -- prints the figures of paper_earth's exported C API that docs/c_api.md
 * quotes: the size of a saved state (paper_earth_state_size) and the number of blocks
 * paper_earth_create allocates, counted through a user allocator.  tests/test_export_c.py
 * builds it strictly against the export and compares the page with its output:
 *   state_size <bytes>
 *   blocks <count>
 */
#include <stdio.h>
#include <stdlib.h>

#include "paper_earth.h"

#include "checks.h"

static void *counting_allocate(void *ctx, size_t size) {
    (*(long *)ctx)++;
    return malloc(size);
}
static void counting_free(void *ctx, void *p) {
    (void)ctx;
    free(p);
}

int main(void) {
    long n_blocks = 0;
    const gyrowheel_allocator a = {counting_allocate, counting_free, &n_blocks};
    paper_earth *w = NULL;
    CHECK(paper_earth_create(NULL, NULL, NULL, &a, &w) == GYROWHEEL_OK);
    printf("state_size %lu\nblocks %ld\n", (unsigned long)paper_earth_state_size(w), n_blocks);
    paper_earth_free(w);
    fprintf(stderr, "capi_figures: %d checks, %d failures\n", h_checks, h_failures);
    return h_failures == 0 ? 0 : 1;
}
