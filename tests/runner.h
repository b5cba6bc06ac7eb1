/* Runs a table of Unity tests and reports each result as a TAP line on
 * stdout, which Meson counts one test at a time (protocol: 'tap').
 *
 * Unity's own report goes to stderr (tests/unity/unity_config.h). A test is
 * "ok" when Unity saw no failure, "not ok" when it did, and "ok ... # SKIP"
 * when it called TEST_IGNORE_MESSAGE. Each test may have its own setup and
 * teardown (Unity's setUp/tearDown, defined in runner.c, call them).
 *
 *   static const lt_test tests[] = { LT_TEST(test_a), LT_TEST_FIXTURE(test_b, up, down) };
 *   int main(void) { return LT_RUN(tests); }
 *
 * A setup run once before all the tests and a teardown once after them
 * (group fixtures): LT_RUN_GROUP(tests, setup, teardown).
 *
 * LOCD_TEST_FILTER=substring runs only the tests whose name contains it. */
#ifndef LOCD_TEST_RUNNER_H
#define LOCD_TEST_RUNNER_H

#include <stddef.h>
#include <stdio.h>

#include "unity.h"

typedef struct lt_test {
    const char *name;
    void (*fn)(void);
    void (*setup)(void);    /* may be NULL */
    void (*teardown)(void); /* may be NULL; runs even when the test failed */
} lt_test;

#define LT_TEST(f) { #f, f, NULL, NULL }
#define LT_TEST_FIXTURE(f, up, down) { #f, f, up, down }

/* Fails the running test with a printf-style message. */
#define LT_FAIL(...) lt_fail_(__LINE__, __VA_ARGS__)
void lt_fail_(int line, const char *fmt, ...);

/* TEST_ASSERT_EQUAL_MEMORY for any size_t length, where zero bytes compare
 * equal (Unity fails a zero length as "pointless" and takes a 32-bit length);
 * a difference is reported with its byte offset. */
#define LT_ASSERT_EQUAL_MEMORY(expected, actual, len) lt_assert_equal_memory_(__LINE__, (expected), (actual), (len))
void lt_assert_equal_memory_(int line, const void *expected, const void *actual, size_t len);

/* Prints a note to stderr, beside Unity's report. */
#define LT_PRINT(...) ((void)fprintf(stderr, __VA_ARGS__))

/* Returns the process exit status: 0 if no test failed, 1 otherwise. */
int lt_run(const char *file, const lt_test *tests, size_t n);
#define LT_RUN(tests) lt_run(__FILE__, (tests), sizeof(tests) / sizeof((tests)[0]))

/* lt_run between a setup and a teardown run once each (either may be NULL).
 * The setup returns 0 when ready; when it returns non-zero or one of its
 * assertions fails, no test runs and every one is reported "not ok". The
 * teardown runs in every case; a failed assertion in it fails the run. */
int lt_run_group(const char *file, const lt_test *tests, size_t n, int (*setup)(void), void (*teardown)(void));
#define LT_RUN_GROUP(tests, setup, teardown) \
    lt_run_group(__FILE__, (tests), sizeof(tests) / sizeof((tests)[0]), (setup), (teardown))

#endif
