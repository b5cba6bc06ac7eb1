/* A small JSON reader (RFC 8259 subset: no \u escapes beyond ASCII) for
 * scene files. Parses a whole document into a tree; errors carry line and
 * column. */
#ifndef LOCD_TOOLS_JSON_H
#define LOCD_TOOLS_JSON_H

#include <stddef.h>
#include <stdio.h>

enum { JSON_NULL, JSON_FALSE, JSON_TRUE, JSON_NUMBER, JSON_STRING, JSON_ARRAY, JSON_OBJECT };

typedef struct json_value {
    int type;
    double number;
    char *string;             /* JSON_STRING */
    size_t count;             /* JSON_ARRAY, JSON_OBJECT */
    struct json_value *items; /* count values */
    char **keys;              /* JSON_OBJECT: count keys */
} json_value;

/* NULL on error, with a message "line L, column C: ..." in err. */
json_value *json_parse(const char *text, char *err, size_t errlen);
/* Reads and parses a file; path "-" reads stdin. */
json_value *json_parse_file(const char *path, char *err, size_t errlen);
void json_free(json_value *v);
/* Writes s as a JSON string, quotes included: a quote and a backslash
 * are escaped, control characters written as \u00XX, so that a name or a
 * path from the user cannot break the JSON the tool prints. */
void json_write_string(FILE *f, const char *s);

/* Member of an object, or NULL. */
const json_value *json_get(const json_value *obj, const char *key);
/* Typed look-ups with a default when the member is missing. They return -1
 * (and leave *out alone) when the member has the wrong type. */
int json_get_number(const json_value *obj, const char *key, double *out);
int json_get_bool(const json_value *obj, const char *key, int *out);
int json_get_string(const json_value *obj, const char *key, const char **out);
/* An array of exactly n numbers into out; 0 missing, 1 read, -1 wrong. */
int json_get_vec(const json_value *obj, const char *key, double *out, size_t n);

#endif
