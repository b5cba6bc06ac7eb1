/* A small recursive-descent JSON reader for scene files. */
#include "json.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct parser {
    const char *s, *p;
    char *err;
    size_t errlen;
    int failed;
    int depth;
} parser;

static void fail(parser *ps, const char *fmt, ...)
{
    const char *q;
    int line = 1, col = 1, n;
    va_list ap;
    if (ps->failed)
        return;
    ps->failed = 1;
    for (q = ps->s; q < ps->p; q++) {
        if (*q == '\n') {
            line++;
            col = 1;
        } else {
            col++;
        }
    }
    n = snprintf(ps->err, ps->errlen, "line %d, column %d: ", line, col);
    if (n < 0 || (size_t)n >= ps->errlen)
        return;
    va_start(ap, fmt);
    vsnprintf(ps->err + n, ps->errlen - (size_t)n, fmt, ap);
    va_end(ap);
}

static void skip_ws(parser *ps)
{
    while (*ps->p == ' ' || *ps->p == '\t' || *ps->p == '\n' || *ps->p == '\r')
        ps->p++;
}

static int parse_value(parser *ps, json_value *v);

static char *parse_string_raw(parser *ps)
{
    size_t cap = 16, len = 0;
    char *out = malloc(cap);
    if (!out) {
        fail(ps, "out of memory");
        return NULL;
    }
    ps->p++; /* opening quote */
    for (;;) {
        char c = *ps->p;
        if (c == '\0' || c == '\n') {
            fail(ps, "unterminated string");
            free(out);
            return NULL;
        }
        ps->p++;
        if (c == '"')
            break;
        if (c == '\\') {
            char e = *ps->p++;
            switch (e) {
            case '"': c = '"'; break;
            case '\\': c = '\\'; break;
            case '/': c = '/'; break;
            case 'b': c = '\b'; break;
            case 'f': c = '\f'; break;
            case 'n': c = '\n'; break;
            case 'r': c = '\r'; break;
            case 't': c = '\t'; break;
            case 'u': {
                unsigned code = 0;
                int k;
                for (k = 0; k < 4; k++) {
                    char h = *ps->p++;
                    code <<= 4;
                    if (h >= '0' && h <= '9')
                        code |= (unsigned)(h - '0');
                    else if (h >= 'a' && h <= 'f')
                        code |= (unsigned)(h - 'a' + 10);
                    else if (h >= 'A' && h <= 'F')
                        code |= (unsigned)(h - 'A' + 10);
                    else {
                        fail(ps, "bad \\u escape");
                        free(out);
                        return NULL;
                    }
                }
                c = code < 128 ? (char)code : '?'; /* scene files are ASCII */
                break;
            }
            default:
                fail(ps, "bad escape \\%c", e);
                free(out);
                return NULL;
            }
        }
        if (len + 2 > cap) {
            char *q = realloc(out, cap *= 2);
            if (!q) {
                free(out);
                fail(ps, "out of memory");
                return NULL;
            }
            out = q;
        }
        out[len++] = c;
    }
    out[len] = '\0';
    return out;
}

static int parse_container(parser *ps, json_value *v, int object)
{
    size_t cap = 0;
    char close = object ? '}' : ']';
    v->type = object ? JSON_OBJECT : JSON_ARRAY;
    if (++ps->depth > 64) {
        fail(ps, "nested too deeply");
        return -1;
    }
    ps->p++;
    skip_ws(ps);
    if (*ps->p == close) {
        ps->p++;
        ps->depth--;
        return 0;
    }
    for (;;) {
        char *key = NULL;
        skip_ws(ps);
        if (object) {
            if (*ps->p != '"') {
                fail(ps, "expected a member name in quotes");
                return -1;
            }
            if (!(key = parse_string_raw(ps)))
                return -1;
            skip_ws(ps);
            if (*ps->p != ':') {
                fail(ps, "expected ':' after \"%s\"", key);
                free(key);
                return -1;
            }
            ps->p++;
        }
        if (v->count == cap) {
            size_t ncap = cap ? 2 * cap : 8;
            json_value *items = realloc(v->items, ncap * sizeof *items);
            char **keys = object ? realloc(v->keys, ncap * sizeof *keys) : NULL;
            if (items)
                v->items = items;
            if (keys)
                v->keys = keys;
            if (!items || (object && !keys)) {
                free(key);
                fail(ps, "out of memory");
                return -1;
            }
            cap = ncap;
        }
        memset(&v->items[v->count], 0, sizeof v->items[0]);
        if (object)
            v->keys[v->count] = key;
        v->count++;
        if (parse_value(ps, &v->items[v->count - 1]) != 0)
            return -1;
        skip_ws(ps);
        if (*ps->p == ',') {
            ps->p++;
            continue;
        }
        if (*ps->p == close) {
            ps->p++;
            ps->depth--;
            return 0;
        }
        fail(ps, "expected ',' or '%c'", close);
        return -1;
    }
}

static int parse_value(parser *ps, json_value *v)
{
    skip_ws(ps);
    switch (*ps->p) {
    case '{':
        return parse_container(ps, v, 1);
    case '[':
        return parse_container(ps, v, 0);
    case '"':
        v->type = JSON_STRING;
        v->string = parse_string_raw(ps);
        return v->string ? 0 : -1;
    case 't':
        if (!strncmp(ps->p, "true", 4)) {
            v->type = JSON_TRUE;
            ps->p += 4;
            return 0;
        }
        break;
    case 'f':
        if (!strncmp(ps->p, "false", 5)) {
            v->type = JSON_FALSE;
            ps->p += 5;
            return 0;
        }
        break;
    case 'n':
        if (!strncmp(ps->p, "null", 4)) {
            v->type = JSON_NULL;
            ps->p += 4;
            return 0;
        }
        break;
    default:
        if (*ps->p == '-' || (*ps->p >= '0' && *ps->p <= '9')) {
            char *end;
            errno = 0;
            v->type = JSON_NUMBER;
            v->number = strtod(ps->p, &end);
            if (end == ps->p || errno == ERANGE) {
                fail(ps, "bad number");
                return -1;
            }
            ps->p = end;
            return 0;
        }
    }
    fail(ps, *ps->p ? "unexpected character '%c'" : "unexpected end of file", *ps->p);
    return -1;
}

json_value *json_parse(const char *text, char *err, size_t errlen)
{
    parser ps = {text, text, err, errlen, 0, 0};
    json_value *v = calloc(1, sizeof *v);
    if (!v) {
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    if (parse_value(&ps, v) == 0) {
        skip_ws(&ps);
        if (*ps.p == '\0')
            return v;
        fail(&ps, "text after the document");
    }
    json_free(v);
    return NULL;
}

json_value *json_parse_file(const char *path, char *err, size_t errlen)
{
    FILE *f = fopen(path, "rb");
    char *text;
    long size;
    json_value *v;
    if (!f) {
        snprintf(err, errlen, "cannot open: %s", strerror(errno));
        return NULL;
    }
    if (fseek(f, 0, SEEK_END) != 0 || (size = ftell(f)) < 0 || fseek(f, 0, SEEK_SET) != 0 ||
        !(text = malloc((size_t)size + 1)) || fread(text, 1, (size_t)size, f) != (size_t)size) {
        snprintf(err, errlen, "cannot read");
        fclose(f);
        return NULL;
    }
    fclose(f);
    text[size] = '\0';
    v = json_parse(text, err, errlen);
    free(text);
    return v;
}

static void json_free_inner(json_value *v)
{
    size_t i;
    free(v->string);
    for (i = 0; i < v->count; i++) {
        json_free_inner(&v->items[i]);
        if (v->keys)
            free(v->keys[i]);
    }
    free(v->items);
    free(v->keys);
}

void json_free(json_value *v)
{
    if (!v)
        return;
    json_free_inner(v);
    free(v);
}

const json_value *json_get(const json_value *obj, const char *key)
{
    size_t i;
    if (!obj || obj->type != JSON_OBJECT)
        return NULL;
    for (i = 0; i < obj->count; i++)
        if (!strcmp(obj->keys[i], key))
            return &obj->items[i];
    return NULL;
}

int json_get_number(const json_value *obj, const char *key, double *out)
{
    const json_value *v = json_get(obj, key);
    if (!v)
        return 0;
    if (v->type != JSON_NUMBER)
        return -1;
    *out = v->number;
    return 1;
}

int json_get_bool(const json_value *obj, const char *key, int *out)
{
    const json_value *v = json_get(obj, key);
    if (!v)
        return 0;
    if (v->type != JSON_TRUE && v->type != JSON_FALSE)
        return -1;
    *out = v->type == JSON_TRUE;
    return 1;
}

int json_get_string(const json_value *obj, const char *key, const char **out)
{
    const json_value *v = json_get(obj, key);
    if (!v)
        return 0;
    if (v->type != JSON_STRING)
        return -1;
    *out = v->string;
    return 1;
}

int json_get_vec(const json_value *obj, const char *key, double *out, size_t n)
{
    const json_value *v = json_get(obj, key);
    size_t i;
    if (!v)
        return 0;
    if (v->type != JSON_ARRAY || v->count != n)
        return -1;
    for (i = 0; i < n; i++)
        if (v->items[i].type != JSON_NUMBER)
            return -1;
    for (i = 0; i < n; i++)
        out[i] = v->items[i].number;
    return 1;
}
