/* TAP on stdout from Unity's per-test results (see runner.h). */
#include "runner.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const lt_test *current;

void setUp(void)
{
    if (current && current->setup)
        current->setup();
}

void tearDown(void)
{
    if (current && current->teardown)
        current->teardown();
}

void lt_fail_(int line, const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    UNITY_TEST_FAIL((UNITY_LINE_TYPE)line, msg);
}

void lt_assert_equal_memory_(int line, const void *expected, const void *actual, size_t len)
{
    const unsigned char *e = expected, *a = actual;
    char msg[96];
    size_t i;
    if (len == 0)
        return;
    UNITY_TEST_ASSERT_NOT_NULL(expected, line, "expected memory is NULL");
    UNITY_TEST_ASSERT_NOT_NULL(actual, line, "actual memory is NULL");
    if (memcmp(e, a, len) == 0)
        return;
    for (i = 0; e[i] == a[i]; i++)
        ;
    snprintf(msg, sizeof msg, "memory differs at byte %zu of %zu", i, len);
    UNITY_TEST_ASSERT_EQUAL_HEX8(e[i], a[i], line, msg);
}

static size_t planned_tests(const lt_test *tests, size_t n, const char *filter)
{
    size_t i, planned = 0;
    for (i = 0; i < n; i++)
        planned += !filter || strstr(tests[i].name, filter) != NULL;
    return planned;
}

static void run_tests(const lt_test *tests, size_t n, const char *filter)
{
    size_t i, k = 0;
    for (i = 0; i < n; i++) {
        UNITY_COUNTER_TYPE failures = Unity.TestFailures, ignores = Unity.TestIgnores;
        if (filter && !strstr(tests[i].name, filter))
            continue;
        current = &tests[i];
        UnityDefaultTestRun(tests[i].fn, tests[i].name, 0);
        current = NULL;
        k++;
        if (Unity.TestFailures != failures)
            printf("not ok %zu - %s\n", k, tests[i].name);
        else if (Unity.TestIgnores != ignores)
            printf("ok %zu - %s # SKIP\n", k, tests[i].name);
        else
            printf("ok %zu - %s\n", k, tests[i].name);
        fflush(stdout);
    }
}

int lt_run(const char *file, const lt_test *tests, size_t n)
{
    return lt_run_group(file, tests, n, NULL, NULL);
}

static int (*group_setup)(void);
static int group_setup_status;

static void call_group_setup(void)
{
    group_setup_status = group_setup();
}

/* Calls fn outside any test, guarded as Unity guards a test, so that a
 * failed assertion in it returns here. 1 when it failed. */
static int guarded(void (*fn)(void), const char *name)
{
    int failed;
    Unity.CurrentTestName = name;
    Unity.CurrentTestFailed = 0;
    if (TEST_PROTECT())
        fn();
    failed = Unity.CurrentTestFailed != 0;
    if (failed)
        LT_PRINT("\n"); /* Unity's failure line has no end of its own outside a test */
    Unity.CurrentTestFailed = 0;
    Unity.CurrentTestIgnored = 0;
    Unity.CurrentTestName = NULL;
    return failed;
}

int lt_run_group(const char *file, const lt_test *tests, size_t n, int (*setup)(void), void (*teardown)(void))
{
    const char *filter = getenv("LOCD_TEST_FILTER");
    size_t i, k = 0, planned = planned_tests(tests, n, filter);

    printf("1..%zu\n", planned);
    fflush(stdout);

    UnityBegin(file);
    group_setup = setup;
    group_setup_status = 0;
    if (setup && (guarded(call_group_setup, "group setup") || group_setup_status != 0)) {
        LT_PRINT("%s: group setup failed (%d): no test ran\n", file, group_setup_status);
        for (i = 0; i < n; i++)
            if (!filter || strstr(tests[i].name, filter))
                printf("not ok %zu - %s # group setup failed\n", ++k, tests[i].name);
        fflush(stdout);
        Unity.TestFailures++; /* so that Unity's summary says FAIL too */
    } else {
        run_tests(tests, n, filter);
    }
    if (teardown && guarded(teardown, "group teardown")) {
        printf("# group teardown failed\n");
        fflush(stdout);
        Unity.TestFailures++;
    }
    return UnityEnd() != 0;
}
