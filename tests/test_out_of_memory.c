/* Real out of memory: the system allocator returns NULL (no allocator hook,
 * which test_alloc_failure covers allocation by allocation). With the
 * address space limited (RLIMIT_AS) to a little more than the process
 * already maps, a find on a million-box scene cannot get its buffers: it
 * must return LOCD_ERR_NO_MEMORY with a message, leave the output as it
 * was, and not crash; with the limit lifted, the same engine and output
 * then give the reference bytes. This is what a 10^8-object call on a
 * machine without the memory meets (docs/benchmarks.md, "From 10^3 to
 * 10^8"), when the kernel refuses the mapping rather than overcommitting.
 * ASan and TSan reserve terabytes of address space, so under them the test
 * is ignored. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "runner.h"

#include "support.h"

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define OOM_UNDER_SANITIZER 1
#endif

/* The process's mapped address space now, in bytes (0 if unknown). */
static size_t mapped_bytes(void)
{
    FILE *f = fopen("/proc/self/statm", "r");
    unsigned long pages = 0;
    if (!f)
        return 0;
    if (fscanf(f, "%lu", &pages) != 1)
        pages = 0;
    fclose(f);
    return (size_t)pages * 4096u;
}

static locd_engine *engine_with(uint32_t threads)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_engine_config_init(&cfg);
    cfg.threads = threads;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
    return e;
}

static void find_without_address_space_says_no_memory(void)
{
#ifdef OOM_UNDER_SANITIZER
    TEST_IGNORE_MESSAGE("the sanitizers reserve more address space than any limit this test could set");
#else
    const size_t n = 1000000;
    float *boxes = ts_scene(0, n, 99), *small = ts_scene(0, 1000, 5);
    locd_pairs *ref = NULL, *out = NULL;
    locd_engine *e;
    struct rlimit old, tight;
    size_t before;
    locd_status st;
    TEST_ASSERT_NOT_NULL(boxes);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &ref));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &out));
    /* An engine whose threads are started and whose buffers have not grown
       yet (nothing the big call needs is mapped: freed heap memory would
       be), and an output holding an earlier result. */
    e = engine_with(2);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, small, 1000, 0, out));
    {
        const size_t was = locd_pairs_count(out);
        TEST_ASSERT_TRUE(was > 0);
        uint32_t *saved = malloc(was * 2 * sizeof(uint32_t) + 1);
        TEST_ASSERT_NOT_NULL(saved);
        memcpy(saved, locd_pairs_data(out), was * 2 * sizeof(uint32_t));
        TEST_ASSERT_EQUAL_INT(0, getrlimit(RLIMIT_AS, &old));
        before = mapped_bytes();
        TEST_ASSERT_TRUE(before > 0);
        /* 16 MB more than mapped now: the call needs about 60 MB more. */
        tight = old;
        tight.rlim_cur = (rlim_t)(before + ((size_t)16 << 20));
        TEST_ASSERT_EQUAL_INT(0, setrlimit(RLIMIT_AS, &tight));
        st = locd_engine_find_pairs_f32(e, boxes, n, 0, out);
        TEST_ASSERT_EQUAL_INT(0, setrlimit(RLIMIT_AS, &old));
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NO_MEMORY, st);
        TEST_ASSERT_TRUE(strlen(locd_last_error()) > 0);
        LT_PRINT("  limited to %zu MB: %s\n", (size_t)(tight.rlim_cur >> 20), locd_last_error());
        TEST_ASSERT_EQUAL_UINT64(was, locd_pairs_count(out));
        TEST_ASSERT_EQUAL_MEMORY(saved, locd_pairs_data(out), was * 2 * sizeof(uint32_t));
        free(saved);
    }
    /* The limit lifted, the same engine and output work: the pairs of
       another engine. */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, boxes, n, 0, out));
    locd_engine_destroy(e);
    e = engine_with(2);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, boxes, n, 0, ref));
    TEST_ASSERT_TRUE(locd_pairs_count(ref) > n / 2);
    TEST_ASSERT_EQUAL_UINT64(locd_pairs_count(ref), locd_pairs_count(out));
    TEST_ASSERT_EQUAL_MEMORY(locd_pairs_data(ref), locd_pairs_data(out), locd_pairs_count(ref) * 2 * sizeof(uint32_t));
    locd_engine_destroy(e);
    locd_pairs_destroy(ref);
    locd_pairs_destroy(out);
    free(boxes);
    free(small);
#endif
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(find_without_address_space_says_no_memory),
    };
    return LT_RUN(tests);
}
