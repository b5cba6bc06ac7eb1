/* Step 3: merge k sorted runs into one. The engine splits the output by rank
 * so that k threads merge disjoint slices (the paper's master merged alone,
 * which was its bottleneck). */
#include "octree/octree.h"

void lc_merge_split(const uint64_t *const *runs, const size_t *counts, size_t k, size_t rank, size_t *pos)
{
    size_t r, total = 0;
    uint64_t lo = 0, hi = UINT64_MAX;
    for (r = 0; r < k; r++)
        total += counts[r];
    if (rank >= total) {
        for (r = 0; r < k; r++)
            pos[r] = counts[r];
        return;
    }
    /* The rank-th smallest value x (entries are unique): smallest v with
       at least rank + 1 values <= v. */
    while (lo < hi) {
        uint64_t mid = lo + (hi - lo) / 2;
        size_t c = 0;
        for (r = 0; r < k; r++) /* values <= mid; mid < hi, so mid + 1 does not wrap */
            c += lc_lower_bound(runs[r], counts[r], mid + 1);
        if (c >= rank + 1)
            hi = mid;
        else
            lo = mid + 1;
    }
    for (r = 0; r < k; r++)
        pos[r] = lc_lower_bound(runs[r], counts[r], lo);
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
