/* The workload of `locd frames` (frames_motion.h). */
#include "frames_motion.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A uniform draw in [0, bound). */
static size_t below(cli_rng *r, size_t bound)
{
    return (size_t)(cli_rng_uniform(r) * (double)bound);
}

/* The first k entries of a become a uniform random k-subset (partial
 * Fisher-Yates: O(k)). */
static void pick(cli_rng *r, uint32_t *a, size_t len, size_t k)
{
    size_t i;
    for (i = 0; i < k && i < len; i++) {
        size_t j = i + below(r, len - i);
        uint32_t t = a[i];
        a[i] = a[j];
        a[j] = t;
    }
}

int frames_motion_init(frames_motion *m, const float *boxes, size_t n, double static_frac, double moving,
                       uint64_t seed)
{
    uint32_t *all;
    size_t i, nstatic = (size_t)floor(static_frac * (double)n + 0.5), k = 0;
    double edge = 0.0;
    memset(m, 0, sizeof *m);
    m->n = n;
    m->is_static = calloc(n + 1, 1);
    m->mark = calloc(n + 1, 1);
    all = malloc((n + 1) * sizeof *all);
    m->dynamic = malloc((n + 1) * sizeof *m->dynamic);
    if (!m->is_static || !m->mark || !all || !m->dynamic) {
        free(all);
        frames_motion_free(m);
        return -1;
    }
    cli_rng_seed(&m->rng, seed);
    for (i = 0; i < n; i++)
        all[i] = (uint32_t)i;
    if (nstatic > n)
        nstatic = n;
    pick(&m->rng, all, n, nstatic);
    for (i = 0; i < nstatic; i++)
        m->is_static[all[i]] = 1;
    free(all);
    for (i = 0; i < n; i++)
        if (!m->is_static[i])
            m->dynamic[k++] = (uint32_t)i;
    m->ndynamic = k;
    m->moved = (size_t)floor(moving * (double)k + 0.5);
    if (m->moved > k)
        m->moved = k;
    for (i = 0; i < n; i++)
        edge += ((double)boxes[6 * i + 3] - boxes[6 * i] + (double)boxes[6 * i + 4] - boxes[6 * i + 1] +
                 (double)boxes[6 * i + 5] - boxes[6 * i + 2]) / 3.0;
    m->step = n ? 0.03 * edge / (double)n : 0.0;
    return 0;
}

/* Puts a[0, k) in ascending order: a mark per index, then one pass over
 * them, O(n) (the movers are a large share of the scene at 100% moving). */
static void sort_movers(frames_motion *m, uint32_t *a, size_t k)
{
    size_t i, w = 0;
    if (k < 2)
        return;
    for (i = 0; i < k; i++)
        m->mark[a[i]] = 1;
    for (i = 0; i < m->n; i++)
        if (m->mark[i])
            m->mark[i] = 0, a[w++] = (uint32_t)i;
}

void frames_motion_step(frames_motion *m, float *boxes)
{
    size_t i;
    int a;
    pick(&m->rng, m->dynamic, m->ndynamic, m->moved);
    sort_movers(m, m->dynamic, m->moved);
    for (i = 0; i < m->moved; i++) {
        float *b = boxes + 6 * (size_t)m->dynamic[i];
        for (a = 0; a < 3; a++) {
            /* The same float shift of min and max keeps min <= max (rounding is monotone). */
            float d = (float)((2.0 * cli_rng_uniform(&m->rng) - 1.0) * m->step);
            b[a] += d;
            b[3 + a] += d;
        }
    }
}

void frames_motion_free(frames_motion *m)
{
    free(m->is_static);
    free(m->mark);
    free(m->dynamic);
    m->is_static = NULL;
    m->mark = NULL;
    m->dynamic = NULL;
}
