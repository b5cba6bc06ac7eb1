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

int lt_run(const char *file, const lt_test *tests, size_t n)
{
    const char *filter = getenv("LOCD_TEST_FILTER");
    size_t i, planned = 0, k = 0;
    int failed_any;

    for (i = 0; i < n; i++)
        planned += !filter || strstr(tests[i].name, filter) != NULL;
    printf("1..%zu\n", planned);
    fflush(stdout);

    UnityBegin(file);
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
    failed_any = UnityEnd() != 0;
    return failed_any;
}
