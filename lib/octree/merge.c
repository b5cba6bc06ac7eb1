/* Step 3: merge k sorted runs into one. The engine splits the output by rank
 * so that k threads merge disjoint slices (the paper's master merged alone,
 * which was its bottleneck). */
#include "octree/octree.h"

typedef struct merge_rank {
    const uint64_t *const *runs;
    const size_t *counts;
    size_t k, rank;
} merge_rank;

/* At least rank + 1 values of the runs are <= v. */
static int holds_rank(const void *ctx, uint64_t v)
{
    const merge_rank *m = (const merge_rank *)ctx;
    size_t r, c = 0;
    for (r = 0; r < m->k; r++) /* values <= v; v < UINT64_MAX (the search's hi), so v + 1 does not wrap */
        c += lc_lower_bound(m->runs[r], m->counts[r], v + 1);
    return c >= m->rank + 1;
}

void lc_merge_split(const uint64_t *const *runs, const size_t *counts, size_t k, size_t rank, size_t *pos)
{
    size_t r, total = 0;
    merge_rank m;
    uint64_t x;
    for (r = 0; r < k; r++)
        total += counts[r];
    if (rank >= total) {
        for (r = 0; r < k; r++)
            pos[r] = counts[r];
        return;
    }
    /* The rank-th smallest value x (entries are unique): the smallest v
       with at least rank + 1 values <= v. */
    m.runs = runs, m.counts = counts, m.k = k, m.rank = rank;
    x = lc_search_first(0, UINT64_MAX, holds_rank, &m);
    for (r = 0; r < k; r++)
        pos[r] = lc_lower_bound(runs[r], counts[r], x);
}

static void merge2(const uint64_t *a, const uint64_t *ae, const uint64_t *b, const uint64_t *be, uint64_t *out)
{
    while (a < ae && b < be) {
        uint64_t x = *a, y = *b;
        int take_a = x < y;
        *out++ = take_a ? x : y;
        a += take_a;
        b += !take_a;
    }
    while (a < ae)
        *out++ = *a++;
    while (b < be)
        *out++ = *b++;
}

/* k-way merge with a binary heap of run heads. */
static void merge_heap(const uint64_t *const *runs, const size_t *begin, const size_t *end, size_t k, uint64_t *out)
{
    size_t heap[LC_MAX_THREADS], cur[LC_MAX_THREADS], hn = 0, r;
    for (r = 0; r < k; r++) {
        cur[r] = begin[r];
        if (cur[r] < end[r]) {
            size_t j = hn++;
            while (j > 0 && runs[heap[(j - 1) / 2]][cur[heap[(j - 1) / 2]]] > runs[r][cur[r]]) {
                heap[j] = heap[(j - 1) / 2];
                j = (j - 1) / 2;
            }
            heap[j] = r;
        }
    }
    while (hn) {
        size_t top = heap[0], j = 0, moving;
        uint64_t mv;
        *out++ = runs[top][cur[top]++];
        if (cur[top] == end[top])
            moving = heap[--hn];
        else
            moving = top;
        if (!hn)
            break;
        mv = runs[moving][cur[moving]];
        for (;;) {
            size_t c = 2 * j + 1;
            if (c >= hn)
                break;
            if (c + 1 < hn && runs[heap[c + 1]][cur[heap[c + 1]]] < runs[heap[c]][cur[heap[c]]])
                c++;
            if (runs[heap[c]][cur[heap[c]]] >= mv)
                break;
            heap[j] = heap[c];
            j = c;
        }
        heap[j] = moving;
    }
}

void lc_merge_ranges(const uint64_t *const *runs, const size_t *begin, const size_t *end, size_t k, uint64_t *out)
{
    size_t r, live = 0, which[2] = {0, 0};
    for (r = 0; r < k; r++)
        if (begin[r] < end[r] && live < 2)
            which[live++] = r;
    for (r = 0, live = 0; r < k; r++)
        live += begin[r] < end[r];
    if (live == 0)
        return;
    if (live == 1) {
        memcpy(out, runs[which[0]] + begin[which[0]], (end[which[0]] - begin[which[0]]) * sizeof *out);
        return;
    }
    if (live == 2) {
        size_t a = which[0], b = which[1];
        merge2(runs[a] + begin[a], runs[a] + end[a], runs[b] + begin[b], runs[b] + end[b], out);
        return;
    }
    merge_heap(runs, begin, end, k, out);
}
