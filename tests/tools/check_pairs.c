/* check_pairs SCENE.aabb PAIRS.bin [--samples K]
 *
 * An exact broad phase written independently of locd (no octree, no
 * quantization): a uniform hash grid in the scene's own float coordinates,
 * each pair kept in the one cell that holds the low corner of the two boxes'
 * intersection. It recomputes every overlapping pair of the scene and
 * compares with PAIRS.bin (little-endian uint32 i j rows, sorted by (i, j),
 * as `locd pairs --out` writes). K sampled boxes are also checked against a
 * plain O(n) scan of all others. Exit 0 when everything agrees. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct item {
    uint64_t cell;
    uint32_t box;
} item;

static float *B;
static double O[3], H;
static int64_t G; /* cells per axis */

static int64_t cell_of(double x, int a)
{
    int64_t c = (int64_t)floor((x - O[a]) / H);
    return c < 0 ? 0 : (c >= G ? G - 1 : c);
}

static int overlap(uint32_t i, uint32_t j)
{
    const float *a = B + 6 * (size_t)i, *b = B + 6 * (size_t)j;
    return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

static int cmp_item(const void *x, const void *y)
{
    const item *a = x, *b = y;
    if (a->cell != b->cell)
        return a->cell < b->cell ? -1 : 1;
    return (a->box > b->box) - (a->box < b->box);
}

static int cmp_u64(const void *x, const void *y)
{
    uint64_t a = *(const uint64_t *)x, b = *(const uint64_t *)y;
    return (a > b) - (a < b);
}

static void *load(const char *path, size_t *bytes)
{
    FILE *f = fopen(path, "rb");
    void *d;
    long n;
    if (!f || fseek(f, 0, SEEK_END) || (n = ftell(f)) < 0 || fseek(f, 0, SEEK_SET)) {
        fprintf(stderr, "check_pairs: cannot read %s\n", path);
        exit(2);
    }
    d = malloc((size_t)n + 1);
    if (!d || fread(d, 1, (size_t)n, f) != (size_t)n) {
        fprintf(stderr, "check_pairs: cannot read %s\n", path);
        exit(2);
    }
    fclose(f);
    *bytes = (size_t)n;
    return d;
}

int main(int argc, char **argv)
{
    size_t sb, pb, n, m, i, ni = 0, cap, np = 0, pcap, samples = 200;
    uint32_t *given;
    item *items;
    uint64_t *pairs;
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL}, ext = 0;
    int a;
    if (argc < 3) {
        fprintf(stderr, "usage: check_pairs SCENE.aabb PAIRS.bin [--samples K]\n");
        return 2;
    }
    if (argc >= 5 && !strcmp(argv[3], "--samples"))
        samples = (size_t)strtoull(argv[4], NULL, 10);
    B = load(argv[1], &sb);
    given = load(argv[2], &pb);
    n = sb / 24;
    m = pb / 8;
    for (i = 1; i < m; i++) {
        uint64_t p = ((uint64_t)given[2 * i - 2] << 32) | given[2 * i - 1];
        uint64_t q = ((uint64_t)given[2 * i] << 32) | given[2 * i + 1];
        if (p >= q) {
            fprintf(stderr, "check_pairs: pairs file not strictly sorted at row %zu\n", i);
            return 1;
        }
    }
    for (i = 0; i < m; i++)
        if (given[2 * i] >= given[2 * i + 1] || given[2 * i + 1] >= n) {
            fprintf(stderr, "check_pairs: bad pair row %zu: %u %u\n", i, given[2 * i], given[2 * i + 1]);
            return 1;
        }
    for (i = 0; i < n; i++)
        for (a = 0; a < 3; a++) {
            if (B[6 * i + a] < lo[a])
                lo[a] = B[6 * i + a];
            if (B[6 * i + 3 + a] > hi[a])
                hi[a] = B[6 * i + 3 + a];
        }
    for (a = 0; a < 3; a++) {
        O[a] = lo[a];
        if (hi[a] - lo[a] > ext)
            ext = hi[a] - lo[a];
    }
    G = (int64_t)ceil(cbrt((double)(n ? n : 1)));
    if (G < 1)
        G = 1;
    if (G > 2000)
        G = 2000;
    H = ext > 0 ? ext / (double)G : 1.0;
    cap = n * 8 + 16;
    items = malloc(cap * sizeof *items);
    for (i = 0; i < n; i++) {
        int64_t c0[3], c1[3], x, y, z;
        for (a = 0; a < 3; a++) {
            c0[a] = cell_of(B[6 * i + a], a);
            c1[a] = cell_of(B[6 * i + 3 + a], a);
        }
        for (z = c0[2]; z <= c1[2]; z++)
            for (y = c0[1]; y <= c1[1]; y++)
                for (x = c0[0]; x <= c1[0]; x++) {
                    if (ni == cap) {
                        cap *= 2;
                        items = realloc(items, cap * sizeof *items);
                    }
                    items[ni].cell = ((uint64_t)z * (uint64_t)G + (uint64_t)y) * (uint64_t)G + (uint64_t)x;
                    items[ni].box = (uint32_t)i;
                    ni++;
                }
    }
    qsort(items, ni, sizeof *items, cmp_item);
    pcap = m + 1024;
    pairs = malloc(pcap * sizeof *pairs);
    for (i = 0; i < ni;) {
        size_t j = i, u, v;
        while (j < ni && items[j].cell == items[i].cell)
            j++;
        for (u = i; u < j; u++)
            for (v = u + 1; v < j; v++) {
                uint32_t p = items[u].box, q = items[v].box;
                const float *pa = B + 6 * (size_t)p, *qa = B + 6 * (size_t)q;
                uint64_t cell;
                if (!overlap(p, q))
                    continue;
                cell = ((uint64_t)cell_of(pa[2] > qa[2] ? pa[2] : qa[2], 2) * (uint64_t)G +
                        (uint64_t)cell_of(pa[1] > qa[1] ? pa[1] : qa[1], 1)) * (uint64_t)G +
                       (uint64_t)cell_of(pa[0] > qa[0] ? pa[0] : qa[0], 0);
                if (cell != items[i].cell)
                    continue;
                if (np == pcap) {
                    pcap *= 2;
                    pairs = realloc(pairs, pcap * sizeof *pairs);
                }
                pairs[np++] = ((uint64_t)p << 32) | q; /* p < q: items sorted by box within a cell */
            }
        i = j;
    }
    qsort(pairs, np, sizeof *pairs, cmp_u64);
    if (np != m) {
        fprintf(stderr, "check_pairs: MISMATCH: grid finds %zu pairs, file has %zu\n", np, m);
        return 1;
    }
    for (i = 0; i < m; i++)
        if (pairs[i] != (((uint64_t)given[2 * i] << 32) | given[2 * i + 1])) {
            fprintf(stderr, "check_pairs: MISMATCH at row %zu: grid %u %u, file %u %u\n", i,
                    (unsigned)(pairs[i] >> 32), (unsigned)pairs[i], given[2 * i], given[2 * i + 1]);
            return 1;
        }
    /* Sampled rows against a plain scan: every partner of box s. */
    {
        uint64_t x = 88172645463325252ULL;
        size_t k;
        for (k = 0; k < samples && n; k++) {
            size_t s, cnt = 0, j, want = 0;
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            s = (size_t)(x % n);
            for (j = 0; j < n; j++)
                if (j != s && overlap((uint32_t)s, (uint32_t)j))
                    cnt++;
            for (j = 0; j < m; j++)
                if (given[2 * j] == s || given[2 * j + 1] == s)
                    want++;
            if (cnt != want) {
                fprintf(stderr, "check_pairs: MISMATCH: box %zu has %zu partners by scan, %zu in file\n", s, cnt,
                        want);
                return 1;
            }
        }
    }
    printf("check_pairs: %zu boxes, %zu pairs: identical to the independent grid; %zu sampled boxes agree\n", n, m,
           samples);
    free(items);
    free(pairs);
    free(B);
    free(given);
    return 0;
}
