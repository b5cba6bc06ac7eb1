/* The scene files' JSON reader (tools/json.c): values, nesting, escapes,
 * and error positions on malformed input. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../tools/json.h"

static void parses_values(void **state)
{
    char err[128];
    double v[3] = {0, 0, 0}, x = 0;
    int b = -1;
    const char *s = NULL;
    json_value *j = json_parse(" {\"a\": [1, -2.5e1, 3e-1], \"b\": true, \"s\": \"x\\\"y\\n\\u0041\", \"n\": null,"
                               " \"o\": {\"k\": []}} ", err, sizeof err);
    (void)state;
    assert_non_null(j);
    assert_int_equal(json_get_vec(j, "a", v, 3), 1);
    assert_true(v[0] == 1.0 && v[1] == -25.0 && v[2] == 0.3);
    assert_int_equal(json_get_bool(j, "b", &b), 1);
    assert_int_equal(b, 1);
    assert_int_equal(json_get_string(j, "s", &s), 1);
    assert_string_equal(s, "x\"y\nA");
    assert_int_equal(json_get(j, "n")->type, JSON_NULL);
    assert_int_equal(json_get(json_get(j, "o"), "k")->count, 0);
    /* Missing members keep the default; wrong types say so. */
    assert_int_equal(json_get_number(j, "missing", &x), 0);
    assert_int_equal(json_get_number(j, "b", &x), -1);
    assert_int_equal(json_get_vec(j, "a", v, 2), -1);
    json_free(j);
}

static void reports_error_positions(void **state)
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
    (void)state;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char err[128] = "";
        json_value *j = json_parse(cases[i].text, err, sizeof err);
        if (j || !strstr(err, cases[i].want))
            fail_msg("case %zu: got '%s', want '%s'", i, err, cases[i].want);
    }
}

static void nesting_is_bounded(void **state)
{
    char text[300], err[128];
    int i;
    (void)state;
    for (i = 0; i < 100; i++)
        text[i] = '[';
    text[100] = '\0';
    assert_null(json_parse(text, err, sizeof err));
    assert_non_null(strstr(err, "nested too deeply"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(parses_values),
        cmocka_unit_test(reports_error_positions),
        cmocka_unit_test(nesting_is_bounded),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
