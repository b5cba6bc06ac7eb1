/* The scene files' JSON reader (tools/json.c): values, nesting, escapes,
 * and error positions on malformed input. */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "../tools/json.h"

static void parses_values(void)
{
    char err[128];
    double v[3] = {0, 0, 0}, x = 0;
    int b = -1;
    const char *s = NULL;
    json_value *j = json_parse(" {\"a\": [1, -2.5e1, 3e-1], \"b\": true, \"s\": \"x\\\"y\\n\\u0041\", \"n\": null,"
                               " \"o\": {\"k\": []}} ", err, sizeof err);
    TEST_ASSERT_NOT_NULL(j);
    TEST_ASSERT_EQUAL_INT64(1, json_get_vec(j, "a", v, 3));
    TEST_ASSERT_TRUE(v[0] == 1.0 && v[1] == -25.0 && v[2] == 0.3);
    TEST_ASSERT_EQUAL_INT64(1, json_get_bool(j, "b", &b));
    TEST_ASSERT_EQUAL_INT64(1, b);
    TEST_ASSERT_EQUAL_INT64(1, json_get_string(j, "s", &s));
    TEST_ASSERT_EQUAL_STRING("x\"y\nA", s);
    TEST_ASSERT_EQUAL_INT64(JSON_NULL, json_get(j, "n")->type);
    TEST_ASSERT_EQUAL_INT64(0, json_get(json_get(j, "o"), "k")->count);
    /* Missing members keep the default; wrong types say so. */
    TEST_ASSERT_EQUAL_INT64(0, json_get_number(j, "missing", &x));
    TEST_ASSERT_EQUAL_INT64(-1, json_get_number(j, "b", &x));
    TEST_ASSERT_EQUAL_INT64(-1, json_get_vec(j, "a", v, 2));
    json_free(j);
}

static void reports_error_positions(void)
{
    static const struct {
        const char *text, *want;
    } cases[] = {
        {"{\"a\": 1,, }", "line 1, column 9"},
        {"{\n  \"a\": [1, 2\n}", "line 3, column 1"},
        {"{\"a\": tru}", "line 1, column 7"},
        {"{\"a\": \"open", "unterminated"},
        {"[1] 2", "text after"},
        {"", "end of file"},
        {"{\"a\": 1e999}", "bad number"},
    };
    size_t i;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char err[128] = "";
        json_value *j = json_parse(cases[i].text, err, sizeof err);
        if (j || !strstr(err, cases[i].want))
            LT_FAIL("case %zu: got '%s', want '%s'", i, err, cases[i].want);
    }
}

static void nesting_is_bounded(void)
{
    char text[300], err[128];
    int i;
    for (i = 0; i < 100; i++)
        text[i] = '[';
    text[100] = '\0';
    TEST_ASSERT_NULL(json_parse(text, err, sizeof err));
    TEST_ASSERT_NOT_NULL(strstr(err, "nested too deeply"));
}

/* RFC 8259 numbers only: strtod alone would take nan, inf, hex floats,
 * a leading '+', leading zeros and "1." - and a NaN then slips past the
 * scene's range checks (issue 18). Each is refused with its position. */
static void numbers_follow_rfc8259(void)
{
    static const char *bad[] = {"-nan", "nan", "NaN", "-inf", "inf", "Infinity", "0x10", "-0x1p3", "+1",
                                "01", "-01", "1.", ".5", "1e", "1e+", "-", "1.e3", "1e999", "[1, -nan]"};
    static const struct {
        const char *text;
        double want;
    } good[] = {{"0", 0.0}, {"-0", -0.0}, {"12", 12.0}, {"-3.25", -3.25}, {"1e3", 1e3}, {"2E-2", 2e-2},
                {"0.5e+1", 5.0}, {"1e-400", 0.0}};
    char err[128];
    size_t i;
    for (i = 0; i < sizeof bad / sizeof *bad; i++) {
        json_value *j = json_parse(bad[i], err, sizeof err);
        if (j)
            json_free(j);
        TEST_ASSERT_NULL_MESSAGE(j, bad[i]);
        TEST_ASSERT_NOT_NULL_MESSAGE(strstr(err, "column"), err);
    }
    for (i = 0; i < sizeof good / sizeof *good; i++) {
        json_value *j = json_parse(good[i].text, err, sizeof err);
        TEST_ASSERT_NOT_NULL_MESSAGE(j, good[i].text);
        TEST_ASSERT_EQUAL_INT64(JSON_NUMBER, j->type);
        TEST_ASSERT_TRUE_MESSAGE(j->number == good[i].want, good[i].text);
        json_free(j);
    }
    TEST_ASSERT_NULL(json_parse("{\"points\": -nan}", err, sizeof err));
    TEST_ASSERT_EQUAL_STRING("line 1, column 12: bad number (RFC 8259: -?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)?)",
                             err);
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(parses_values),
        LT_TEST(reports_error_positions),
        LT_TEST(nesting_is_bounded),
        LT_TEST(numbers_follow_rfc8259),
    };
    return LT_RUN(tests);
}
