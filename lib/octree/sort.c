/* Sorts k runs of 64-bit entries into one array on the pool, with no merge
 * pass: every thread scatters its run into 2^d buckets of the top bits
 * that vary (thread t's share of a bucket after thread t-1's, so entries
 * with equal high bits keep the runs' order), then the threads take the
 * buckets in turn and sort each, small enough for the cache, with
 * lc_radix_sort (a thread on a slower core takes fewer).
 *
 * Why: the engine's threads used to radix sort their own runs (four
 * passes over their entries, each scattering to 2,048 places out of the
 * cache) and then merge the runs (one more pass over everything). Here one
 * pass leaves the cache; the buckets' passes stay in it.
 *
 * A scene whose entries nearly all share their top bits (a cluster and a
 * few boxes far away: the grid spans both) would put them in one bucket,
 * sorted by one thread. When a bucket holds more than a thread's share,
 * the threads sort their own runs and merge them instead, as before. */
#include "octree/octree.h"

/* Buckets hold about 2^17 entries at most (1 MiB, the second cache
 * level), and there are at least 8 per thread so that the threads, taking
 * them in turn, end about together. Smaller buckets cost more than they
 * save: below about 2^13 entries the counts of each pass (2^bits of them)
 * weigh as much as the entries (measured on mixed35's 1.5 million entries
 * while one thread also sorted this way: 2^10-entry buckets 15.5 ms,
 * 2^17-entry ones 9.1; one thread now radix sorts its region directly). */
#define LC_PSORT_BUCKET_LOG2 17
#define LC_LINE 64 /* bytes in a cache line */
#define LC_LINE_WORDS (LC_LINE / sizeof(size_t))
#define LC_PSORT_MAX_DIGIT 11

typedef struct psort_ctx {
    const lc_psort_in *in;
    uint64_t *out, *scratch;
    uint64_t or_[LC_MAX_THREADS], and_[LC_MAX_THREADS];
    uint32_t shift, digit;
    size_t *count; /* k rows of 2^digit (row t at count + t * stride): counts, then where thread t writes
                      each bucket */
    size_t stride; /* a row's words: whole cache lines, so no two threads' counters share one */
    size_t *start; /* 2^digit + 1: where each bucket starts in out */
    uint32_t next_bucket; /* the next bucket to sort (atomic) */
    int pass;
} psort_ctx;

static void count_digit(const uint64_t *r, size_t n, uint32_t sh, uint32_t digit, size_t *h)
{
    const uint64_t mask = ((uint64_t)1 << digit) - 1;
    size_t i;
    memset(h, 0, sizeof(size_t) << digit);
    for (i = 0; i < n; i++)
        h[(r[i] >> sh) & mask]++;
}

/* The bits that vary, and the counts of the digit at the top of the key
 * (where it nearly always is: the octree's first split varies), in one
 * read of the run. */
static void or_and_count(psort_ctx *c, uint32_t t)
{
    const uint64_t *r = c->in->run[t];
    const uint64_t mask = ((uint64_t)1 << c->digit) - 1;
    const uint32_t sh = c->shift;
    uint64_t o = 0, a = ~(uint64_t)0;
    size_t *h = c->count + t * c->stride, i, n = c->in->count[t];
    memset(h, 0, sizeof(size_t) << c->digit);
    for (i = 0; i < n; i++) {
        const uint64_t v = r[i];
        o |= v, a &= v;
        h[(v >> sh) & mask]++;
    }
    c->or_[t] = o, c->and_[t] = a;
}

static void scatter(psort_ctx *c, uint32_t t)
{
    const uint64_t *r = c->in->run[t];
    const uint64_t mask = ((uint64_t)1 << c->digit) - 1;
    const uint32_t sh = c->shift;
    size_t *w = c->count + t * c->stride, i, n = c->in->count[t];
    uint64_t *out = c->out;
    for (i = 0; i < n; i++) {
        const uint64_t v = r[i];
        out[w[(v >> sh) & mask]++] = v;
    }
}

static void sort_buckets(psort_ctx *c, uint32_t t)
{
    uint32_t b;
    (void)t;
    while ((b = __atomic_fetch_add(&c->next_bucket, 1, __ATOMIC_RELAXED)) < (1u << c->digit)) {
        const size_t s = c->start[b], n = c->start[b + 1] - s;
        const uint64_t *r = lc_radix_sort(c->out + s, c->scratch + s, n, c->in->index_bits);
        if (r != c->out + s)
            memcpy(c->out + s, r, n * sizeof *r);
    }
}

/* The skewed case: thread t radix sorts its own run in place (out, free
 * until the merge, is its scratch), then merges its slice of the output. */
static void sort_own_run(psort_ctx *c, uint32_t t)
{
    size_t off = 0;
    uint32_t u;
    uint64_t *r;
    for (u = 0; u < t; u++)
        off += c->in->count[u];
    r = lc_radix_sort(c->in->run[t], c->out + off, c->in->count[t], c->in->index_bits);
    if (r != c->in->run[t])
        memcpy(c->in->run[t], r, c->in->count[t] * sizeof *r);
}

static void merge_slice(psort_ctx *c, uint32_t t, uint32_t k)
{
    const uint64_t *runs[LC_MAX_THREADS];
    size_t lo[LC_MAX_THREADS], hi[LC_MAX_THREADS], total = 0, r0, r1;
    uint32_t u;
    for (u = 0; u < k; u++)
        runs[u] = c->in->run[u], total += c->in->count[u];
    r0 = total * t / k, r1 = total * (t + 1) / k;
    lc_merge_split(runs, c->in->count, k, r0, lo);
    lc_merge_split(runs, c->in->count, k, r1, hi);
    lc_merge_ranges(runs, lo, hi, k, c->out + r0);
}

static void task_psort(void *arg, uint32_t t, uint32_t k)
{
    psort_ctx *c = arg;
    switch (c->pass) {
    case 0: or_and_count(c, t); break;
    case 1: count_digit(c->in->run[t], c->in->count[t], c->shift, c->digit, c->count + t * c->stride); break;
    case 2: scatter(c, t); break;
    case 3: sort_buckets(c, t); break;
    case 4: sort_own_run(c, t); break;
    default: merge_slice(c, t, k); break;
    }
}

static void run_pass(lc_pool *pool, psort_ctx *c, int pass)
{
    c->pass = pass;
    if (c->in->k > 1)
        lc_pool_run(pool, c->in->k, task_psort, c);
    else
        task_psort(c, 0, 1);
}

/* The digit's width for total entries on k threads (see LC_PSORT_BUCKET_LOG2). */
static uint32_t digit_width(size_t total, uint32_t k)
{
    uint32_t d = 1;
    while (d < LC_PSORT_MAX_DIGIT && ((total >> (LC_PSORT_BUCKET_LOG2 + d)) > 0 || (1u << d) < 8 * k))
        d++;
    return d;
}

/* The top bits that vary above index_bits, at most *d of them, as the
 * digit's shift; narrows *d when fewer vary. 0 when no bit varies. */
static int top_varying(const psort_ctx *c, uint32_t *d, uint32_t *shift)
{
    uint64_t o = 0, a = ~(uint64_t)0, diff;
    uint32_t t, hb, lb;
    for (t = 0; t < c->in->k; t++)
        o |= c->or_[t], a &= c->and_[t];
    diff = (o ^ a) >> c->in->index_bits;
    if (!diff)
        return 0;
    hb = 63u - (uint32_t)__builtin_clzll(diff) + c->in->index_bits;
    lb = (uint32_t)__builtin_ctzll(diff) + c->in->index_bits;
    if (*d > hb - lb + 1)
        *d = hb - lb + 1;
    *shift = hb + 1 - *d;
    return 1;
}

/* The entries of the largest bucket. */
static size_t largest_bucket(const psort_ctx *c)
{
    size_t most = 0;
    uint32_t b, t;
    for (b = 0; b < (1u << c->digit); b++) {
        size_t n = 0;
        for (t = 0; t < c->in->k; t++)
            n += c->count[t * c->stride + b];
        most = n > most ? n : most;
    }
    return most;
}

/* Each bucket's start and each thread's offsets in it. */
static void plan_buckets(psort_ctx *c)
{
    const uint32_t k = c->in->k, nb = 1u << c->digit;
    uint32_t b, t;
    size_t s = 0;
    for (b = 0; b < nb; b++) {
        c->start[b] = s;
        for (t = 0; t < k; t++) {
            size_t *h = c->count + t * c->stride + b, n = *h;
            *h = s;
            s += n;
        }
    }
    c->start[nb] = s;
    c->next_bucket = 0;
}

locd_status lc_psort(lc_pool *pool, const locd_allocator *alloc, const lc_psort_in *in, uint64_t *out, uint64_t *scratch)
{
    psort_ctx c;
    size_t total = 0, words;
    void *raw;
    uint32_t t, d, shift = 0;
    memset(&c, 0, sizeof c);
    c.in = in, c.out = out, c.scratch = scratch;
    for (t = 0; t < in->k; t++)
        total += in->count[t];
    d = digit_width(total, in->k);
    /* Each thread's row of counters on cache lines of its own: rows that
       shared a line (the allocator's 16-byte alignment put a row's end and
       the next row's start in one) had every increment there bounce between
       the cores; the passes that count and scatter ran much slower, and
       whether they did changed with the heap's layout from one build to
       the next. */
    c.stride = ((((size_t)1 << d) + LC_LINE_WORDS - 1) / LC_LINE_WORDS) * LC_LINE_WORDS;
    words = in->k * c.stride + ((size_t)1 << d) + 1 + LC_LINE_WORDS;
    if (!(raw = lc_alloc(alloc, words * sizeof(size_t))))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the sort's %zu counts", words);
    c.count = (size_t *)(void *)(((uintptr_t)raw + LC_LINE - 1) & ~(uintptr_t)(LC_LINE - 1));
    c.start = c.count + in->k * c.stride;
    c.digit = d, c.shift = 64 - d;
    if (in->key_bits && in->index_bits + in->key_bits <= 64) {
        if (c.digit > in->key_bits)
            c.digit = in->key_bits;
        c.shift = in->index_bits + in->key_bits - c.digit;
    }
    run_pass(pool, &c, 0);
    if (!top_varying(&c, &d, &shift)) { /* one key: the runs in order are sorted */
        uint64_t *o = out;
        for (t = 0; t < in->k; t++) {
            memcpy(o, in->run[t], in->count[t] * sizeof *o);
            o += in->count[t];
        }
    } else {
        if (d != c.digit || shift != c.shift) { /* the top bits did not vary: count again */
            c.digit = d, c.shift = shift;
            run_pass(pool, &c, 1);
        }
        if (in->k > 1 && largest_bucket(&c) > total / in->k) {
            run_pass(pool, &c, 4);
            run_pass(pool, &c, 5);
        } else {
            plan_buckets(&c);
            run_pass(pool, &c, 2);
            run_pass(pool, &c, 3);
        }
    }
    lc_free(alloc, raw, words * sizeof(size_t));
    return LOCD_OK;
}
