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

#define NUMBER_GRAMMAR "RFC 8259: -?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)?"

static int is_digit(char c)
{
    return c >= '0' && c <= '9';
}

/* The end of an RFC 8259 number starting at p, or NULL. strtod alone would
 * also take nan, inf, hex floats and "1." - a NaN then passes every range
 * check written as `x < lo || x > hi` (issue 18). */
static const char *number_end(const char *p)
{
    if (*p == '-')
        p++;
    if (*p == '0')
        p++;
    else if (*p >= '1' && *p <= '9')
        while (is_digit(*p))
            p++;
    else
        return NULL;
    if (*p == '.') {
        if (!is_digit(*++p))
            return NULL;
        while (is_digit(*p))
            p++;
    }
    if (*p == 'e' || *p == 'E') {
        p++;
        if (*p == '+' || *p == '-')
            p++;
        if (!is_digit(*p))
            return NULL;
        while (is_digit(*p))
            p++;
    }
    return p;
}

/* A number: the strict grammar, then strtod over exactly that text; a
 * value past the double range is refused (an underflow reads as 0 or a
 * subnormal). 0, or -1 after fail(). */
static int parse_number(parser *ps, json_value *v)
{
    const char *end = number_end(ps->p);
    char *stop;
    /* A letter or dot right after the digits ("1.", "0x10", "01", "1e") is
     * part of a malformed number, not the next token. */
    if (!end || is_digit(*end) || *end == '.' || *end == 'x' || *end == 'X' || *end == 'e' || *end == 'E') {
        fail(ps, "bad number (" NUMBER_GRAMMAR ")");
        return -1;
    }
    errno = 0;
    v->type = JSON_NUMBER;
    v->number = strtod(ps->p, &stop);
    if (stop != end || (errno == ERANGE && (v->number > 1.0 || v->number < -1.0))) {
        fail(ps, "bad number (" NUMBER_GRAMMAR ")");
        return -1;
    }
    ps->p = end;
    return 0;
}

/* The 4 hex digits of a \u escape; scene files are ASCII, so a code point
 * past 127 reads as '?'. 0, or -1 after fail(). */
static int parse_hex4(parser *ps, char *c)
{
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
            return -1;
        }
    }
    *c = code < 128 ? (char)code : '?';
    return 0;
}

/* The character the escape after a backslash stands for; 0, or -1 after fail(). */
static int parse_escape(parser *ps, char *c)
{
    char e = *ps->p++;
    switch (e) {
    case '"': *c = '"'; break;
    case '\\': *c = '\\'; break;
    case '/': *c = '/'; break;
    case 'b': *c = '\b'; break;
    case 'f': *c = '\f'; break;
    case 'n': *c = '\n'; break;
    case 'r': *c = '\r'; break;
    case 't': *c = '\t'; break;
    case 'u': return parse_hex4(ps, c);
    default: fail(ps, "bad escape \\%c", e); return -1;
    }
    return 0;
}

/* A string as it grows, with room for the terminating NUL. */
typedef struct strbuf {
    char *s;
    size_t len, cap;
} strbuf;

static int strbuf_put(parser *ps, strbuf *b, char c)
{
    if (b->len + 2 > b->cap) {
        char *q = realloc(b->s, b->cap *= 2);
        if (!q) {
            fail(ps, "out of memory");
            return -1;
        }
        b->s = q;
    }
    b->s[b->len++] = c;
    return 0;
}

/* The string at the opening quote, unescaped (malloc); NULL after fail(). */
static char *parse_string_raw(parser *ps)
{
    strbuf b = {NULL, 0, 16};
    if (!(b.s = malloc(b.cap))) {
        fail(ps, "out of memory");
        return NULL;
    }
    ps->p++; /* opening quote */
    for (;;) {
        char c = *ps->p;
        if (c == '\0' || c == '\n') {
            fail(ps, "unterminated string");
            break;
        }
        ps->p++;
        if (c == '"') {
            b.s[b.len] = '\0';
            return b.s;
        }
        if ((c == '\\' && parse_escape(ps, &c) != 0) || strbuf_put(ps, &b, c) != 0)
            break;
    }
    free(b.s);
    return NULL;
}

/* An object member's name and the ':' after it; 0, or -1 after fail(). */
static int parse_member_name(parser *ps, char **key)
{
    if (*ps->p != '"') {
        fail(ps, "expected a member name in quotes");
        return -1;
    }
    if (!(*key = parse_string_raw(ps)))
        return -1;
    skip_ws(ps);
    if (*ps->p != ':') {
        fail(ps, "expected ':' after \"%s\"", *key);
        free(*key);
        *key = NULL;
        return -1;
    }
    ps->p++;
    return 0;
}

/* A new zeroed item at the end of v, with its key in an object (v owns it
 * from here); NULL after fail(), the key freed. */
static json_value *add_item(parser *ps, json_value *v, size_t *cap, int object, char *key)
{
    if (v->count == *cap) {
        size_t ncap = *cap ? 2 * *cap : 8;
        json_value *items = realloc(v->items, ncap * sizeof *items);
        char **keys = object ? realloc(v->keys, ncap * sizeof *keys) : NULL;
        if (items)
            v->items = items;
        if (keys)
            v->keys = keys;
        if (!items || (object && !keys)) {
            free(key);
            fail(ps, "out of memory");
            return NULL;
        }
        *cap = ncap;
    }
    memset(&v->items[v->count], 0, sizeof v->items[0]);
    if (object)
        v->keys[v->count] = key;
    return &v->items[v->count++];
}

/* After an item: 1 at a ',' (another item follows), 0 at the closing
 * bracket (the container ends), -1 after fail(). */
static int next_item(parser *ps, char close)
{
    skip_ws(ps);
    if (*ps->p == ',') {
        ps->p++;
        return 1;
    }
    if (*ps->p == close) {
        ps->p++;
        ps->depth--;
        return 0;
    }
    fail(ps, "expected ',' or '%c'", close);
    return -1;
}

static int parse_container(parser *ps, json_value *v, int object)
{
    size_t cap = 0;
    char close = object ? '}' : ']';
    int more;
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
    do {
        char *key = NULL;
        json_value *item;
        skip_ws(ps);
        if (object && parse_member_name(ps, &key) != 0)
            return -1;
        if (!(item = add_item(ps, v, &cap, object, key)) || parse_value(ps, item) != 0)
            return -1;
        more = next_item(ps, close);
    } while (more > 0);
    return more;
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
        if (*ps->p == '-' || (*ps->p >= '0' && *ps->p <= '9'))
            return parse_number(ps, v);
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

/* All of stdin, NUL-terminated (malloc'd), or NULL. */
static char *read_stdin(size_t *size)
{
    size_t cap = 1 << 16, len = 0, got;
    char *text = malloc(cap + 1), *bigger;
    while (text && (got = fread(text + len, 1, cap - len, stdin)) > 0) {
        len += got;
        if (len == cap) {
            if (!(bigger = realloc(text, 2 * cap + 1))) {
                free(text);
                return NULL;
            }
            text = bigger;
            cap *= 2;
        }
    }
    if (text && ferror(stdin)) {
        free(text);
        return NULL;
    }
    *size = len;
    return text;
}

json_value *json_parse_file(const char *path, char *err, size_t errlen)
{
    FILE *f;
    char *text;
    long size;
    json_value *v;
    if (!strcmp(path, "-")) { /* the scene on stdin */
        size_t len = 0;
        if (!(text = read_stdin(&len))) {
            snprintf(err, errlen, "cannot read stdin");
            return NULL;
        }
        text[len] = '\0';
        v = json_parse(text, err, errlen);
        free(text);
        return v;
    }
    f = fopen(path, "rb");
    if (!f) {
        snprintf(err, errlen, "cannot open: %s", strerror(errno));
        return NULL;
    }
    /* fopen opens a directory, and ftell then says LONG_MAX: read a byte
     * first (portable C: no fstat on every target this file builds for). */
    errno = 0;
    if (getc(f) == EOF && ferror(f)) {
        snprintf(err, errlen, "%s", errno == EISDIR ? "is a directory, not a scene file" : "cannot read");
        fclose(f);
        return NULL;
    }
    rewind(f);
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

void json_write_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; s && *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            fprintf(f, "\\%c", c);
        else if (c < 0x20 || c == 0x7f)
            fprintf(f, "\\u%04x", c);
        else
            fputc(c, f);
    }
    fputc('"', f);
}
