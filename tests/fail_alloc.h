/* A counting allocator for the public allocator hook that can fail the k-th
 * allocation. Thread-safe: the library allocates from its worker threads. */
#ifndef LOCD_TEST_FAIL_ALLOC_H
#define LOCD_TEST_FAIL_ALLOC_H

#include <locd/locd.h>
#include <stddef.h>
#include <stdint.h>

typedef struct fa_counts {
    uint64_t calls;       /* alloc calls since the last fa_arm() */
    uint64_t failures;    /* allocations refused since the last fa_arm() */
    uint64_t live_blocks; /* blocks not yet freed (all time) */
    uint64_t live_bytes;
    uint64_t bad_frees;   /* free() of an unknown block or with a size that differs from the alloc's */
} fa_counts;

/* The hook to put in locd_engine_config.allocator or pass to locd_pairs_create. */
const locd_allocator *fa_allocator(void);
/* Fails the k-th allocation from now on (1-based) and every later one when
 * `sticky`; k = 0 disarms (nothing fails). Resets calls and failures. */
void fa_arm(uint64_t k, int sticky);
void fa_counts_get(fa_counts *out);

#endif
