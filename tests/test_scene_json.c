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

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(parses_values),
        LT_TEST(reports_error_positions),
        LT_TEST(nesting_is_bounded),
    };
    return LT_RUN(tests);
}
