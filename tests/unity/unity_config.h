/* Unity configuration for locd's C tests (Unity reads it because the build
 * defines UNITY_INCLUDE_CONFIG_H).
 *
 * Unity's own report (one line per test and "N Tests N Failures N Ignored")
 * goes to stderr, so that stdout carries only the TAP stream that
 * tests/runner.c derives from Unity's per-test results and Meson counts. */
#ifndef LOCD_UNITY_CONFIG_H
#define LOCD_UNITY_CONFIG_H

#include <stdio.h>

#define UNITY_OUTPUT_CHAR(a) ((void)putc((a), stderr))
#define UNITY_OUTPUT_FLUSH() ((void)fflush(stderr))
#define UNITY_INCLUDE_DOUBLE
#define UNITY_SUPPORT_64

#endif
