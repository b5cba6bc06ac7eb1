/* An independent count of the overlapping pairs of a scene (.aabb), for
 * checking locd at sizes brute force cannot reach (bench/scale.sh, docs/
 * benchmarks.md "From 10^3 to 10^8"). It shares no code with locd: a
 * uniform grid whose cell edge is at least the largest box extent, so two
 * overlapping boxes have low-corner cells at most one apart on each axis;
 * the boxes are sorted by the cell of their low corner, and each box is
 * tested (closed intervals, on the file's floats) against the later boxes
 * of its own cell and every box of the 13 neighbour cells that come after
 * its cell in the sort order, so each pair is seen once. Fast when boxes are
 * of similar size (uniform cubes); correct for any scene.
 *   count_pairs SCENE.aabb   -> prints {"n":N,"pairs":M} */
#define _POSIX_C_SOURCE 200809L
#include <fcntl.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#define GMAX 1024u /* cells per axis: keys fit in 30 bits */

static int overlap(const float *a, const float *b)
{
    return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

/* LSD radix sort of v[0, n) by bits 32..63 (the cell key), 8 bits a pass. */
static uint64_t *sort_by_key(uint64_t *v, uint64_t *tmp, size_t n)
{
    unsigned shift;
    for (shift = 32; shift < 64; shift += 8) {
        size_t count[256] = {0}, i, sum = 0;
        uint64_t *t;
        for (i = 0; i < n; i++)
            count[(v[i] >> shift) & 255]++;
        for (i = 0; i < 256; i++) {
            size_t c = count[i];
            count[i] = sum;
            sum += c;
        }
        for (i = 0; i < n; i++)
            tmp[count[(v[i] >> shift) & 255]++] = v[i];
        t = v;
        v = tmp;
        tmp = t;
    }
    return v;
}

int main(int argc, char **argv)
{
    struct stat stt;
    const float *b;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, ext = 0, cell;
    uint64_t *v, *tmp, *s, pairs = 0;
    size_t n, i, p;
    uint32_t g[3];
    int fd, a;
    if (argc != 2) {
        fprintf(stderr, "usage: count_pairs SCENE.aabb\n");
        return 2;
    }
    if ((fd = open(argv[1], O_RDONLY)) < 0 || fstat(fd, &stt) != 0) {
        perror(argv[1]);
        return 1;
    }
    n = (size_t)stt.st_size / 24;
    if (n < 2) {
        printf("{\"n\":%zu,\"pairs\":0}\n", n);
        return 0;
    }
    b = mmap(NULL, (size_t)stt.st_size, PROT_READ, MAP_PRIVATE, fd, 0);
    if (b == MAP_FAILED) {
        perror("mmap");
        return 1;
    }
    for (i = 0; i < n; i++)
        for (a = 0; a < 3; a++) {
            const double l = b[6 * i + a], h = b[6 * i + 3 + a];
            if (!(l <= h)) {
                fprintf(stderr, "box %zu is not a box\n", i);
                return 1;
            }
            lo[a] = l < lo[a] ? l : lo[a];
            hi[a] = h > hi[a] ? h : hi[a];
            ext = h - l > ext ? h - l : ext;
        }
    /* A cell a little wider than the widest box, and no more than GMAX a side. */
    cell = ext * 1.001 + 1e-30;
    for (a = 0; a < 3; a++)
        if ((hi[a] - lo[a]) / cell > GMAX - 1)
            cell = (hi[a] - lo[a]) / (GMAX - 1);
    cell *= 1.000001;
    for (a = 0; a < 3; a++) { /* at least 3 a side: the runs below stay disjoint */
        g[a] = (uint32_t)((hi[a] - lo[a]) / cell) + 1;
        g[a] = g[a] < 3 ? 3 : g[a];
    }
    v = malloc(n * sizeof *v);
    tmp = malloc(n * sizeof *tmp);
    if (!v || !tmp) {
        fprintf(stderr, "out of memory\n");
        return 1;
    }
    for (i = 0; i < n; i++) {
        uint64_t c[3];
        for (a = 0; a < 3; a++) {
            double t = floor((b[6 * i + a] - lo[a]) / cell);
            c[a] = t < 0 ? 0 : t >= g[a] ? g[a] - 1 : (uint64_t)t;
        }
        v[i] = (((c[2] * g[1] + c[1]) * g[0] + c[0]) << 32) | i;
    }
    s = sort_by_key(v, tmp, n);
    {
        /* The 13 later neighbour cells as 5 runs of consecutive keys:
           (dz, dy) = (0, 0) dx = 1; (0, 1) dx = -1..1; (1, -1..1) dx = -1..1.
           Runs are disjoint and never hold the own cell; a run that wraps
           round a grid edge only adds candidates, which the exact test
           rejects. first[r] and past[r] only move forward. */
        const int64_t gx = g[0], gxy = (int64_t)g[0] * g[1];
        const int64_t from[5] = {1, gx - 1, gxy - gx - 1, gxy - 1, gxy + gx - 1};
        const int64_t to[5] = {1, gx + 1, gxy - gx + 1, gxy + 1, gxy + gx + 1};
        size_t first[5] = {0}, past[5] = {0};
        for (p = 0; p < n;) {
            const int64_t key = (int64_t)(s[p] >> 32);
            size_t q = p, r, x, y, t;
            while (q < n && (int64_t)(s[q] >> 32) == key)
                q++;
            for (r = 0; r < 5; r++) {
                while (first[r] < n && (int64_t)(s[first[r]] >> 32) < key + from[r])
                    first[r]++;
                if (past[r] < first[r])
                    past[r] = first[r];
                while (past[r] < n && (int64_t)(s[past[r]] >> 32) <= key + to[r])
                    past[r]++;
            }
            for (x = p; x < q; x++) {
                const float *bx = b + 6 * (uint32_t)s[x];
                for (y = x + 1; y < q; y++)
                    pairs += (uint64_t)overlap(bx, b + 6 * (uint32_t)s[y]);
                for (r = 0; r < 5; r++)
                    for (t = first[r]; t < past[r]; t++)
                        pairs += (uint64_t)overlap(bx, b + 6 * (uint32_t)s[t]);
            }
            p = q;
        }
    }
    printf("{\"n\":%zu,\"pairs\":%llu}\n", n, (unsigned long long)pairs);
    free(v);
    free(tmp);
    return 0;
}
