/* Scene files, random numbers and small helpers for the locd tool. */
#include "cli.h"

#include <errno.h>
#include <stdint.h>
#include <sys/stat.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static void die_v(const char *fmt, va_list ap)
{
    fputs("locd: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    exit(2);
}

void cli_die(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    die_v(fmt, ap);
    va_end(ap);
}

static int ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && strcmp(s + a - b, suffix) == 0;
}

/* 1 when the open file f is a directory (fopen opens one for reading). */
static int is_directory(FILE *f)
{
    struct stat sb;
    return fstat(fileno(f), &sb) == 0 && S_ISDIR(sb.st_mode);
}

/* The whole of a file, or of stdin for "-", in one malloc'd block. */
static int read_all(const char *path, unsigned char **data, size_t *size)
{
    const int from_stdin = !strcmp(path, "-");
    FILE *f = from_stdin ? stdin : fopen(path, "rb");
    size_t cap = 1 << 16, len = 0, got;
    unsigned char *buf;
    if (!f) {
        fprintf(stderr, "locd: cannot open %s: %s\n", path, strerror(errno));
        return -1;
    }
    if (is_directory(f)) { /* fopen opens one; reading it fails with a vague message */
        fprintf(stderr, "locd: %s is a directory, not a scene file\n", from_stdin ? "stdin" : path);
        if (!from_stdin)
            fclose(f);
        return -1;
    }
    if (!from_stdin) { /* a file's size is known: no doubling past it (a 2.4 GB scene took 4 GB) */
        struct stat st;
        if (fstat(fileno(f), &st) == 0 && S_ISREG(st.st_mode) && (uintmax_t)st.st_size < SIZE_MAX)
            cap = (size_t)st.st_size + 1; /* + 1: the read that sees the end needs room */
    }
    buf = malloc(cap);
    while (buf && (got = fread(buf + len, 1, cap - len, f)) > 0) {
        len += got;
        if (len == cap) {
            unsigned char *bigger = cap > SIZE_MAX / 2 ? NULL : realloc(buf, cap * 2);
            if (!bigger) {
                free(buf);
                buf = NULL;
                break;
            }
            buf = bigger;
            cap *= 2;
        }
    }
    if (!buf || ferror(f)) {
        fprintf(stderr, "locd: cannot read %s%s\n", from_stdin ? "stdin" : path, buf ? "" : " (out of memory)");
        free(buf);
        if (!from_stdin)
            fclose(f);
        return -1;
    }
    if (!from_stdin)
        fclose(f);
    *data = buf;
    *size = len;
    return 0;
}

/* The value of key `key` in a .npy header (a Python dict literal): points
 * just past the colon, or NULL. */
static const char *npy_value(const char *header, const char *key)
{
    char quoted[32];
    const char *p;
    snprintf(quoted, sizeof quoted, "'%s'", key);
    if (!(p = strstr(header, quoted)))
        return NULL;
    p += strlen(quoted);
    while (*p == ' ')
        p++;
    if (*p != ':')
        return NULL;
    p++;
    while (*p == ' ')
        p++;
    return p;
}

/* A .npy file (format versions 1-3) holding float32 or float64 (n, 6),
 * C order, little-endian; anything else is refused with the reason. On
 * success the boxes are moved to the start of data. */
static int parse_npy(const char *path, unsigned char *data, size_t size, cli_scene *s)
{
    size_t hlen, start, n = 0, item, need;
    char *header;
    const char *v;
    unsigned long long dims[3];
    int ndim = 0;
    if (size < 10 || data[6] < 1 || data[6] > 3) {
        fprintf(stderr, "locd: %s: not a .npy file of a known version\n", path);
        return -1;
    }
    hlen = data[6] == 1 ? (size_t)data[8] | (size_t)data[9] << 8
                        : (size_t)data[8] | (size_t)data[9] << 8 | (size_t)data[10] << 16 | (size_t)data[11] << 24;
    start = (data[6] == 1 ? 10 : 12) + hlen;
    if (start > size) {
        fprintf(stderr, "locd: %s: truncated .npy header\n", path);
        return -1;
    }
    header = malloc(hlen + 1);
    if (!header)
        cli_die("out of memory");
    memcpy(header, data + (start - hlen), hlen);
    header[hlen] = '\0';
    if (!(v = npy_value(header, "descr")) || (strncmp(v, "'<f4'", 5) && strncmp(v, "'<f8'", 5))) {
        const char *end = v && *v == '\'' ? strchr(v + 1, '\'') : NULL;
        fprintf(stderr, "locd: %s: dtype %.*s is not supported: the boxes must be float32 or float64, "
                        "little-endian ('<f4' or '<f8'), shape (n, 6)%s\n",
                path, end ? (int)(end - v + 1) : 6, v ? v : "(none)",
                v && v[1] == '>' ? "; convert with .astype('<f4') or .astype('<f8')" : "");
        free(header);
        return -1;
    }
    s->f64 = v[3] == '8';
    if (!(v = npy_value(header, "fortran_order")) || strncmp(v, "False", 5)) {
        fprintf(stderr, "locd: %s: the array is in Fortran order: save it in C order "
                        "(numpy.ascontiguousarray) as shape (n, 6)\n",
                path);
        free(header);
        return -1;
    }
    if ((v = npy_value(header, "shape")) && *v == '(') {
        v++;
        while (ndim < 3) {
            char *end;
            while (*v == ' ')
                v++;
            if (*v < '0' || *v > '9')
                break;
            dims[ndim++] = strtoull(v, &end, 10);
            v = end;
            while (*v == ' ' || *v == ',')
                v++;
        }
    }
    free(header);
    if (ndim != 2 || dims[1] != 6) {
        fprintf(stderr, "locd: %s: the array must have shape (n, 6): minx miny minz maxx maxy maxz per row\n", path);
        return -1;
    }
    n = (size_t)dims[0];
    item = s->f64 ? sizeof(double) : sizeof(float);
    if (n > (SIZE_MAX - start) / (6 * item) || (need = n * 6 * item) != size - start) {
        fprintf(stderr, "locd: %s: the data does not hold %llu x 6 values\n", path, dims[0]);
        return -1;
    }
    memmove(data, data + start, need);
    s->n = n;
    return 0;
}

int cli_load_scene(const char *path, cli_scene *s)
{
    static const unsigned char npy_magic[6] = {0x93, 'N', 'U', 'M', 'P', 'Y'};
    const char *name = strcmp(path, "-") ? path : "stdin";
    unsigned char *data;
    size_t size, row;
    memset(s, 0, sizeof *s);
    if (read_all(path, &data, &size) != 0)
        return -1;
    if (ends_with(path, ".npy") || (size >= 6 && !memcmp(data, npy_magic, 6))) {
        if (size < 6 || memcmp(data, npy_magic, 6)) {
            fprintf(stderr, "locd: %s: not a .npy file (no NumPy magic)\n", name);
            free(data);
            return -1;
        }
        if (parse_npy(name, data, size, s) != 0) {
            free(data);
            return -1;
        }
    } else {
        s->f64 = ends_with(path, ".aabb64");
        row = s->f64 ? 48 : 24;
        if (size % row) {
            fprintf(stderr, "locd: %s: size %zu is not a multiple of %zu bytes (one box)\n", name, size, row);
            free(data);
            return -1;
        }
        s->n = size / row;
    }
    if (s->f64)
        s->d = (double *)(void *)data;
    else
        s->f = (float *)(void *)data;
    return 0;
}

void cli_free_scene(cli_scene *s)
{
    free(s->f);
    free(s->d);
    memset(s, 0, sizeof *s);
}

int cli_write_file(const char *path, const void *data, size_t bytes)
{
    const int to_stdout = !strcmp(path, "-");
    FILE *f = to_stdout ? stdout : fopen(path, "wb");
    if (!f) {
        fprintf(stderr, "locd: cannot create %s: %s\n", path, strerror(errno));
        return -1;
    }
    if (bytes && fwrite(data, 1, bytes, f) != bytes) {
        fprintf(stderr, "locd: cannot write %s\n", to_stdout ? "stdout" : path);
        if (!to_stdout)
            fclose(f);
        return -1;
    }
    if (to_stdout ? fflush(f) != 0 : fclose(f) != 0) {
        fprintf(stderr, "locd: cannot write %s\n", to_stdout ? "stdout" : path);
        return -1;
    }
    return 0;
}

int cli_write_pairs(const char *path, const uint32_t *pairs, size_t m)
{
    return cli_write_file(path, pairs, m * 2 * sizeof(uint32_t));
}

int cli_stderr_is_terminal(void)
{
    static int known = -1;
    if (known < 0)
        known = isatty(STDERR_FILENO) ? 1 : 0;
    return known;
}

void cli_progress(const char *what, size_t done, size_t total)
{
    if (!cli_stderr_is_terminal())
        return;
    if (done < total)
        fprintf(stderr, "\rlocd: %s %zu/%zu ", what, done, total);
    else
        fprintf(stderr, "\r\033[K"); /* done: clear the line */
    fflush(stderr);
}

static uint64_t splitmix64(uint64_t *x)
{
    uint64_t z = (*x += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

void cli_rng_seed(cli_rng *r, uint64_t seed)
{
    int i;
    for (i = 0; i < 4; i++)
        r->s[i] = splitmix64(&seed);
}

static uint64_t rotl(uint64_t x, int k)
{
    return (x << k) | (x >> (64 - k));
}

uint64_t cli_rng_next(cli_rng *r)
{
    uint64_t *s = r->s, result = rotl(s[1] * 5, 7) * 9, t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return result;
}

double cli_rng_uniform(cli_rng *r)
{
    return (double)(cli_rng_next(r) >> 11) * (1.0 / 9007199254740992.0);
}

double cli_rng_normal(cli_rng *r)
{
    double u = cli_rng_uniform(r), v = cli_rng_uniform(r);
    if (u < 1e-300)
        u = 1e-300;
    return sqrt(-2.0 * log(u)) * cos(6.283185307179586 * v);
}

const char *cli_generator_kinds(void)
{
    return "uniform, clustered, mixed, lattice, far, boxprune";
}

static void put_box(float *b, double x, double y, double z, double sx, double sy, double sz)
{
    b[0] = (float)x;
    b[1] = (float)y;
    b[2] = (float)z;
    b[3] = (float)(x + sx);
    b[4] = (float)(y + sy);
    b[5] = (float)(z + sz);
}

/* Equal cubes of edge scale w, their low corners uniform in
 * [off, off + scale (1 - w))^3. "uniform" is off 0, scale 1: multiplying by
 * 1 and adding 0 are exact, so its boxes are the plain formula's. */
static void gen_uniform(float *b, size_t n, double w, double off, double scale, cli_rng *r)
{
    size_t i;
    for (i = 0; i < n; i++) {
        /* One draw a statement: the order of a call's arguments is
           unspecified in C, and the scene must not depend on the compiler.
           z, y, x is the order GCC gave the old one-call form, so the
           scenes (and every figure measured on them) stay the same. */
        double z = cli_rng_uniform(r), y = cli_rng_uniform(r), x = cli_rng_uniform(r);
        put_box(b + 6 * i, off + scale * x * (1 - w), off + scale * y * (1 - w), off + scale * z * (1 - w), scale * w,
                scale * w, scale * w);
    }
}

/* Terdiman's box-pruning test scene ("Box pruning revisited"): integer
 * centres uniform in [-2048, 2047]^3, integer half-extents 0..127 drawn
 * per axis (about 11 pairs per box at 10^5 boxes). */
static void gen_boxprune(float *b, size_t n, cli_rng *r)
{
    size_t i;
    for (i = 0; i < n; i++) {
        double c[3], e[3];
        int a;
        for (a = 0; a < 3; a++)
            c[a] = (double)(int64_t)(cli_rng_next(r) % 4096) - 2048.0;
        for (a = 0; a < 3; a++)
            e[a] = (double)(cli_rng_next(r) % 128);
        put_box(b + 6 * i, c[0] - e[0], c[1] - e[1], c[2] - e[2], 2 * e[0], 2 * e[1], 2 * e[2]);
    }
}

/* Half the cubes in 64 Gaussian hot spots, half spread evenly. */
static void gen_clustered(float *b, size_t n, double w, cli_rng *r)
{
    double cx[64], cy[64], cz[64];
    size_t i;
    int c;
    for (c = 0; c < 64; c++) {
        cx[c] = 0.1 + 0.8 * cli_rng_uniform(r);
        cy[c] = 0.1 + 0.8 * cli_rng_uniform(r);
        cz[c] = 0.1 + 0.8 * cli_rng_uniform(r);
    }
    for (i = 0; i < n; i++) {
        double x, y, z, e = 0.5 * w;
        if (cli_rng_next(r) & 1) {
            c = (int)(cli_rng_next(r) % 64);
            x = cx[c] + 0.03 * cli_rng_normal(r);
            y = cy[c] + 0.03 * cli_rng_normal(r);
            z = cz[c] + 0.03 * cli_rng_normal(r);
        } else {
            x = cli_rng_uniform(r);
            y = cli_rng_uniform(r);
            z = cli_rng_uniform(r);
        }
        put_box(b + 6 * i, x, y, z, e, e, e);
    }
}

/* Edges log-uniform over three orders of magnitude, random aspect. */
static void gen_mixed(float *b, size_t n, double w, cli_rng *r)
{
    size_t i;
    for (i = 0; i < n; i++) {
        double s = 0.3 * w * pow(10.0, 3.0 * cli_rng_uniform(r) - 2.0);
        double sx = s * (0.5 + cli_rng_uniform(r)), sy = s * (0.5 + cli_rng_uniform(r)),
               sz = s * (0.5 + cli_rng_uniform(r));
        double z = cli_rng_uniform(r), y = cli_rng_uniform(r), x = cli_rng_uniform(r); /* as in gen_uniform */
        put_box(b + 6 * i, x, y, z, sx, sy, sz);
    }
}

/* Unit cubes on an integer grid, touching faces, edges, corners. */
static void gen_lattice(float *b, size_t n)
{
    size_t m = 1, i, x, y, z;
    while ((m + 1) * (m + 1) * (m + 1) <= n)
        m++;
    for (i = 0; i < n; i++) {
        size_t j = i % (m * m * m);
        x = j % m;
        y = (j / m) % m;
        z = j / (m * m);
        put_box(b + 6 * i, (double)x, (double)y, (double)z, 1.0, 1.0, 1.0);
    }
}

int cli_generator_known(const char *kind)
{
    return !strcmp(kind, "uniform") || !strcmp(kind, "clustered") || !strcmp(kind, "mixed") ||
           !strcmp(kind, "lattice") || !strcmp(kind, "far") || !strcmp(kind, "boxprune");
}

/* Pairs per box of each scalable kind at its natural size (measured on
 * 10^6 boxes, seed 1; nearly independent of n, since the edge shrinks as
 * n^(-1/3)). Scaling every edge by s scales the pairs by about s^3. */
static double natural_pairs_per_box(const char *kind)
{
    if (!strcmp(kind, "uniform"))
        return 1.0094;
    if (!strcmp(kind, "clustered"))
        return 0.5335;
    if (!strcmp(kind, "mixed"))
        return 0.5277;
    return 0.0;
}

int cli_generator_scalable(const char *kind)
{
    return natural_pairs_per_box(kind) > 0.0;
}

float *cli_generate(const char *kind, size_t n, uint64_t seed)
{
    return cli_generate_ppb(kind, n, seed, 0.0);
}

float *cli_generate_ppb(const char *kind, size_t n, uint64_t seed, double pairs_per_box)
{
    cli_rng r;
    float *b;
    /* Edge of n equal cubes in the unit cube giving about one overlapping
       pair per cube: n^2/2 * (2w)^3 = n  =>  w = (4n)^(-1/3). */
    double w = n ? pow(4.0 * (double)n, -1.0 / 3.0) : 0.0;
    if (!cli_generator_known(kind))
        return NULL;
    if (pairs_per_box > 0.0 && cli_generator_scalable(kind))
        w *= cbrt(pairs_per_box / natural_pairs_per_box(kind));
    b = malloc(n ? n * 6 * sizeof(float) : 1);
    if (!b)
        return NULL;
    cli_rng_seed(&r, seed);
    if (!strcmp(kind, "uniform"))
        gen_uniform(b, n, w, 0.0, 1.0, &r);
    else if (!strcmp(kind, "far"))
        /* The uniform scene, 1000 times larger, 1e5 from the origin: float32
           spacing there is 1/128, the cubes about 1000 w. */
        gen_uniform(b, n, w, 1e5, 1000.0, &r);
    else if (!strcmp(kind, "clustered"))
        gen_clustered(b, n, w, &r);
    else if (!strcmp(kind, "mixed"))
        gen_mixed(b, n, w, &r);
    else if (!strcmp(kind, "boxprune"))
        gen_boxprune(b, n, &r);
    else
        gen_lattice(b, n);
    return b;
}

/* The CPU's "model name" from /proc/cpuinfo (for reports). */
void cli_cpu_model(char *buf, size_t len)
{
    FILE *f = fopen("/proc/cpuinfo", "r");
    char line[512];
    snprintf(buf, len, "unknown CPU");
    if (!f)
        return;
    while (fgets(line, sizeof line, f)) {
        if (!strncmp(line, "model name", 10)) {
            char *c = strchr(line, ':');
            if (c) {
                c += 2;
                c[strcspn(c, "\n")] = 0;
                snprintf(buf, len, "%s", c);
            }
            break;
        }
    }
    fclose(f);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

double cli_median(double *v, size_t n)
{
    if (!n)
        return 0.0;
    qsort(v, n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double cli_mean(const double *v, size_t n)
{
    double sum = 0.0;
    size_t i;
    for (i = 0; i < n; i++)
        sum += v[i];
    return n ? sum / (double)n : 0.0;
}

double cli_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

void cli_sleep_ms(double ms)
{
    struct timespec ts;
    ts.tv_sec = (time_t)(ms / 1e3);
    ts.tv_nsec = (long)((ms - (double)ts.tv_sec * 1e3) * 1e6);
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR)
        ;
}

int cli_parse_size(const char *s, size_t *out)
{
    char *end;
    double v;
    errno = 0;
    v = strtod(s, &end);
    if (end == s || errno)
        return -1;
    if (*end == 'k' || *end == 'K') {
        v *= 1e3;
        end++;
    } else if (*end == 'M' || *end == 'm') {
        v *= 1e6;
        end++;
    }
    if (*end || v < 0 || v > 1e12 || v != floor(v))
        return -1;
    *out = (size_t)v;
    return 0;
}

size_t cli_size_option(const char *s, size_t lo, size_t hi, const char *fmt, ...)
{
    size_t v;
    va_list ap;
    if (!cli_parse_size(s, &v) && v >= lo && v <= hi)
        return v;
    va_start(ap, fmt);
    die_v(fmt, ap);
    va_end(ap);
    return 0;
}

uint64_t cli_seed_option(const char *s, const char *cmd)
{
    char *end;
    unsigned long long v;
    errno = 0;
    v = strtoull(s, &end, 10);
    if (*s < '0' || *s > '9' || *end || errno)
        cli_die("%s: bad --seed '%s' (a whole number 0..18446744073709551615)", cmd, s);
    return (uint64_t)v;
}
