/* Batches of queries on the engine's threads, and locd_hits, their
 * result. Every query is checked before any runs (an error names it). The
 * queries go in chunks of LC_BATCH_CHUNK to whichever thread is free; each
 * thread keeps its chunks' hits, and the hits are laid out in query order
 * after: the same for every thread count. */
#include "scene/scene.h"
#include "scene/query.h"

/* Queries a thread takes at a time, and the fewest worth a pool run. */
#define LC_BATCH_CHUNK 64
#define LC_BATCH_SPLIT 256

struct locd_hits {
    uint32_t magic;
    locd_allocator alloc;
    size_t queries, count;
    uint64_t *offsets; /* queries + 1 */
    locd_id *ids;
    double *t;
    size_t off_cap, cap;
    int has_t;
};

locd_status locd_hits_create(const locd_allocator *allocator, locd_hits **out)
{
    locd_allocator a;
    locd_hits *h;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    *out = NULL;
    lc_allocator_resolve(&a, allocator);
    if (!(h = lc_alloc(&a, sizeof *h)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate a hits buffer");
    memset(h, 0, sizeof *h);
    h->magic = LC_MAGIC_HITS;
    h->alloc = a;
    *out = h;
    lc_clear_error();
    return LOCD_OK;
}

void locd_hits_destroy(locd_hits *h)
{
    locd_allocator a;
    if (!h || h->magic != LC_MAGIC_HITS)
        return;
    a = h->alloc;
    lc_free(&a, h->offsets, h->off_cap * sizeof *h->offsets);
    lc_free(&a, h->ids, h->cap * sizeof *h->ids);
    lc_free(&a, h->t, h->cap * sizeof *h->t);
    h->magic = LC_MAGIC_DEAD;
    lc_free(&a, h, sizeof *h);
}

LC_INLINE int hits_ok(const locd_hits *h)
{
    return h && h->magic == LC_MAGIC_HITS;
}

size_t locd_hits_queries(const locd_hits *h)
{
    return hits_ok(h) ? h->queries : 0;
}

size_t locd_hits_count(const locd_hits *h)
{
    return hits_ok(h) ? h->count : 0;
}

const uint64_t *locd_hits_offsets(const locd_hits *h)
{
    return hits_ok(h) ? h->offsets : NULL;
}

const locd_id *locd_hits_ids(const locd_hits *h)
{
    return hits_ok(h) ? h->ids : NULL;
}

const double *locd_hits_t(const locd_hits *h)
{
    return hits_ok(h) && h->has_t ? h->t : NULL;
}

/* Room for n queries' offsets and `count` hits (nothing kept). */
static locd_status hits_room(locd_hits *h, size_t n, size_t count)
{
    if (n + 1 > h->off_cap) {
        uint64_t *o = lc_alloc(&h->alloc, (n + 1) * sizeof *o);
        if (!o)
            return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the batch's hits");
        lc_free(&h->alloc, h->offsets, h->off_cap * sizeof *h->offsets);
        h->offsets = o, h->off_cap = n + 1;
    }
    if (count > h->cap) {
        const size_t cap = lc_grow_cap(h->cap, count);
        locd_id *ids = lc_alloc(&h->alloc, cap * sizeof *ids);
        double *t = lc_alloc(&h->alloc, cap * sizeof *t);
        if (!ids || !t) {
            lc_free(&h->alloc, ids, cap * sizeof *ids);
            lc_free(&h->alloc, t, cap * sizeof *t);
            return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the batch's hits");
        }
        lc_free(&h->alloc, h->ids, h->cap * sizeof *h->ids);
        lc_free(&h->alloc, h->t, h->cap * sizeof *h->t);
        h->ids = ids, h->t = t, h->cap = cap;
    }
    return LOCD_OK;
}

static void hits_empty(locd_hits *h)
{
    h->queries = h->count = 0;
    if (h->offsets)
        h->offsets[0] = 0;
}

/* ---- the batch ---- */

/* A thread's hits (every-hit batches): its chunks' hits in the order it
 * ran them; a line of its own (the threads write theirs at the end). */
typedef struct thread_run {
    lc_hit *hit;
    size_t n, cap;
    char pad[64 - sizeof(lc_hit *) - 2 * sizeof(size_t)];
} thread_run;

/* One batch: its queries (arrays as given), their kind, the filter. */
typedef struct batch {
    const locd_scene *s;
    int kind, f32, point, box; /* box: a cast of boxes, not rays */
    const void *v, *d;          /* boxes, points, origins or centers; directions */
    const double *num;          /* max_t or radii */
    size_t n;
    uint32_t mode;
    const locd_query_filter *filter; /* (checked) */
    int one;                    /* one entry a query (closest, any) */
    locd_hits *out;
    size_t next;                /* the next chunk (atomic) */
    uint64_t *count;            /* every hit: per query */
    thread_run run[LC_MAX_THREADS];
    size_t *chunk_at;           /* every hit: the chunk's first hit in its thread's run */
    uint8_t *chunk_by;          /* and the thread */
    int failed;
} batch;

/* Query k's shape. */
static locd_status shape_of(const batch *b, size_t k, lc_shape *q)
{
    const int w = b->kind == LC_SHAPE_CAST ? (b->box ? 6 : 3) : b->kind == LC_SHAPE_SPHERE ? 3 : (b->point ? 3 : 6);
    const size_t vb = b->f32 ? sizeof(float) : sizeof(double);
    double tv[6], td[3];
    const double *v = lc_widen((const char *)b->v + vb * (size_t)w * k, b->f32, tv, w);
    if (b->kind == LC_SHAPE_BOX)
        return lc_shape_box(q, v, b->point, k);
    if (b->kind == LC_SHAPE_SPHERE)
        return lc_shape_sphere(q, v, b->num[k], k);
    return lc_shape_cast(q, v, b->box, lc_widen((const char *)b->d + vb * 3 * k, b->f32, td, 3), b->num[k], k);
}

/* A walk's hits appended to its thread's run r. 0 on no memory. */
static int keep(const locd_allocator *a, thread_run *r, const lc_walk *w)
{
    if (r->n + w->nhit > r->cap) {
        const size_t cap = lc_grow_cap(r->cap, r->n + w->nhit);
        lc_hit *h = lc_alloc(a, cap * sizeof *h);
        if (!h)
            return 0;
        if (r->n)
            memcpy(h, r->hit, r->n * sizeof *h);
        lc_free(a, r->hit, r->cap * sizeof *h);
        r->hit = h, r->cap = cap;
    }
    if (w->nhit) /* (a run with no hits yet has no array) */
        memcpy(r->hit + r->n, w->hit, w->nhit * sizeof *w->hit);
    r->n += w->nhit;
    return 1;
}

/* Query k on a thread's walk: its best hit into the result, or its hits
 * to the thread's run. 0 on no memory. */
static int one_query(batch *b, lc_walk *w, thread_run *r, size_t k)
{
    lc_shape q;
    shape_of(b, k, &q); /* (checked before the run) */
    w->q = &q;
    if (!lc_walk_run(w))
        return 0;
    if (b->one) {
        b->out->ids[k] = w->best.id, b->out->t[k] = w->best.t;
        return 1;
    }
    lc_walk_sort(w);
    b->count[k] = w->nhit;
    return keep(b->s->alloc, r, w);
}

/* A thread's part: chunks taken until none is left. Its walk and its run
 * are its own until the end (no line shared with another thread's). */
static void task_batch(void *arg, uint32_t t, uint32_t nthreads)
{
    batch *b = arg;
    thread_run r = b->run[t];
    lc_walk w;
    lc_shape none;
    size_t c;
    (void)nthreads;
    none.kind = b->kind;
    lc_walk_init(&w, b->s, &none, b->mode, b->filter, ~(uint64_t)0); /* (the filter was checked) */
    while ((c = __atomic_fetch_add(&b->next, 1, __ATOMIC_RELAXED)) * LC_BATCH_CHUNK < b->n) {
        const size_t first = c * LC_BATCH_CHUNK, end = first + LC_BATCH_CHUNK < b->n ? first + LC_BATCH_CHUNK : b->n;
        size_t q;
        if (!b->one)
            b->chunk_at[c] = r.n, b->chunk_by[c] = (uint8_t)t;
        for (q = first; q < end; q++)
            if (!one_query(b, &w, &r, q)) {
                __atomic_store_n(&b->failed, 1, __ATOMIC_RELAXED);
                goto done;
            }
    }
done:
    lc_walk_fini(b->s->alloc, &w);
    b->run[t] = r;
}

/* The chunks' hits, in query order, into the result. */
static locd_status lay_out(batch *b)
{
    locd_hits *h = b->out;
    const size_t nchunks = (b->n + LC_BATCH_CHUNK - 1) / LC_BATCH_CHUNK;
    size_t k, c, total = 0;
    locd_status st;
    for (k = 0; k < b->n; k++)
        h->offsets[k] = total, total += b->count[k];
    h->offsets[b->n] = total;
    if ((st = hits_room(h, b->n, total)) != LOCD_OK)
        return st;
    for (c = 0; c < nchunks; c++) {
        const size_t first = c * LC_BATCH_CHUNK, end = first + LC_BATCH_CHUNK < b->n ? first + LC_BATCH_CHUNK : b->n;
        const lc_hit *r = b->run[b->chunk_by[c]].hit + b->chunk_at[c];
        for (k = h->offsets[first]; k < h->offsets[end]; k++, r++)
            h->ids[k] = r->id, h->t[k] = r->t;
    }
    h->count = total;
    return LOCD_OK;
}

static void batch_fini(batch *b)
{
    const locd_allocator *a = b->s->alloc;
    const size_t nchunks = (b->n + LC_BATCH_CHUNK - 1) / LC_BATCH_CHUNK;
    uint32_t t;
    for (t = 0; t < LC_MAX_THREADS; t++)
        lc_free(a, b->run[t].hit, b->run[t].cap * sizeof *b->run[t].hit);
    lc_free(a, b->count, (b->n ? b->n : 1) * sizeof *b->count);
    lc_free(a, b->chunk_at, (nchunks ? nchunks : 1) * sizeof *b->chunk_at);
    lc_free(a, b->chunk_by, (nchunks ? nchunks : 1) * sizeof *b->chunk_by);
}

/* The filter checked; the scratch and the result's room. */
static locd_status batch_prepare(batch *b)
{
    const locd_allocator *a = b->s->alloc;
    const size_t nchunks = (b->n + LC_BATCH_CHUNK - 1) / LC_BATCH_CHUNK;
    lc_walk w;
    lc_shape none;
    locd_status st;
    none.kind = b->kind;
    if ((st = lc_walk_init(&w, b->s, &none, b->mode, b->filter, ~(uint64_t)0)) != LOCD_OK)
        return st;
    if ((st = hits_room(b->out, b->n, b->one ? b->n : 0)) != LOCD_OK)
        return st;
    if (b->one)
        return LOCD_OK;
    b->count = lc_alloc(a, (b->n ? b->n : 1) * sizeof *b->count);
    b->chunk_at = lc_alloc(a, (nchunks ? nchunks : 1) * sizeof *b->chunk_at);
    b->chunk_by = lc_alloc(a, (nchunks ? nchunks : 1) * sizeof *b->chunk_by);
    if (!b->count || !b->chunk_at || !b->chunk_by)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the batch's scratch");
    return LOCD_OK;
}

/* The queries run on k threads (the engine's pool when it is free). */
static locd_status batch_run(batch *b)
{
    locd_engine *e = b->s->engine;
    const int pool = b->s->threads > 1 && b->n >= LC_BATCH_SPLIT && lc_engine_acquire(e);
    const uint32_t k = pool ? b->s->threads : 1;
    locd_status st;
    if ((st = batch_prepare(b)) == LOCD_OK) {
        if (pool)
            lc_pool_run(b->s->pool, k, task_batch, b);
        else
            task_batch(b, 0, 1);
        if (b->failed)
            st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the batch's hits");
        else if (b->one)
            b->out->count = b->n;
        else
            st = lay_out(b);
    }
    if (pool)
        lc_engine_release(e);
    return st;
}

static locd_status run_batch(batch *b)
{
    locd_hits *h = b->out;
    lc_shape q;
    locd_status st;
    size_t k;
    if ((st = lc_scene_check_handle(b->s)) != LOCD_OK)
        return st;
    if (!hits_ok(h))
        return lc_error(h ? LOCD_ERR_INVALID_HANDLE : LOCD_ERR_NULL_POINTER, "hits is not a locd_hits handle");
    hits_empty(h);
    if (b->n && (!b->v || (b->kind == LC_SHAPE_CAST && !b->d) || (b->kind != LC_SHAPE_BOX && !b->num)))
        return lc_error(LOCD_ERR_NULL_POINTER, "a query array is NULL");
    if ((st = lc_check_mode(b->mode)) != LOCD_OK)
        return st;
    for (k = 0; k < b->n; k++) /* every query checked before any runs */
        if ((st = shape_of(b, k, &q)) != LOCD_OK)
            return st;
    b->one = b->kind == LC_SHAPE_CAST && b->mode != LOCD_HIT_ALL;
    lc_query_tree_sync(b->s); /* (on no memory the walks try every object) */
    st = batch_run(b);
    batch_fini(b);
    if (st != LOCD_OK) {
        hits_empty(h);
        return st;
    }
    if (b->one)
        for (k = 0; k <= b->n; k++)
            h->offsets[k] = k;
    h->queries = b->n;
    h->has_t = b->kind == LC_SHAPE_CAST;
    lc_clear_error();
    return LOCD_OK;
}

/* A batch of kind `kind`; `alt` a point (overlaps of boxes) or a box
 * (casts). */
static locd_status batch_of(const locd_scene *s, int kind, int alt, int f32, const void *v, const void *d,
                            const double *num, size_t n, uint32_t mode, const locd_query_filter *filter, locd_hits *out)
{
    batch b;
    memset(&b, 0, sizeof b);
    b.s = s, b.kind = kind, b.f32 = f32, b.v = v, b.d = d, b.num = num, b.n = n, b.mode = mode;
    b.point = kind == LC_SHAPE_BOX && alt, b.box = kind == LC_SHAPE_CAST && alt;
    b.filter = filter, b.out = out;
    return run_batch(&b);
}

locd_status locd_scene_cast_ray_batch_f32(const locd_scene *s, const float *origins, const float *directions,
                                          const double *max_t, size_t n, uint32_t mode,
                                          const locd_query_filter *filter, locd_hits *hits)
{
    return batch_of(s, LC_SHAPE_CAST, 0, 1, origins, directions, max_t, n, mode, filter, hits);
}

locd_status locd_scene_cast_ray_batch_f64(const locd_scene *s, const double *origins, const double *directions,
                                          const double *max_t, size_t n, uint32_t mode,
                                          const locd_query_filter *filter, locd_hits *hits)
{
    return batch_of(s, LC_SHAPE_CAST, 0, 0, origins, directions, max_t, n, mode, filter, hits);
}

locd_status locd_scene_cast_box_batch_f32(const locd_scene *s, const float *boxes, const float *directions,
                                          const double *max_t, size_t n, uint32_t mode,
                                          const locd_query_filter *filter, locd_hits *hits)
{
    return batch_of(s, LC_SHAPE_CAST, 1, 1, boxes, directions, max_t, n, mode, filter, hits);
}

locd_status locd_scene_cast_box_batch_f64(const locd_scene *s, const double *boxes, const double *directions,
                                          const double *max_t, size_t n, uint32_t mode,
                                          const locd_query_filter *filter, locd_hits *hits)
{
    return batch_of(s, LC_SHAPE_CAST, 1, 0, boxes, directions, max_t, n, mode, filter, hits);
}

locd_status locd_scene_overlap_box_batch_f32(const locd_scene *s, const float *boxes, size_t n,
                                             const locd_query_filter *filter, locd_hits *hits)
{
    return batch_of(s, LC_SHAPE_BOX, 0, 1, boxes, NULL, NULL, n, LOCD_HIT_ALL, filter, hits);
}

locd_status locd_scene_overlap_box_batch_f64(const locd_scene *s, const double *boxes, size_t n,
                                             const locd_query_filter *filter, locd_hits *hits)
{
    return batch_of(s, LC_SHAPE_BOX, 0, 0, boxes, NULL, NULL, n, LOCD_HIT_ALL, filter, hits);
}

locd_status locd_scene_overlap_point_batch_f32(const locd_scene *s, const float *points, size_t n,
                                               const locd_query_filter *filter, locd_hits *hits)
{
    return batch_of(s, LC_SHAPE_BOX, 1, 1, points, NULL, NULL, n, LOCD_HIT_ALL, filter, hits);
}

locd_status locd_scene_overlap_point_batch_f64(const locd_scene *s, const double *points, size_t n,
                                               const locd_query_filter *filter, locd_hits *hits)
{
    return batch_of(s, LC_SHAPE_BOX, 1, 0, points, NULL, NULL, n, LOCD_HIT_ALL, filter, hits);
}

locd_status locd_scene_overlap_sphere_batch_f32(const locd_scene *s, const float *centers, const double *radii,
                                                size_t n, const locd_query_filter *filter, locd_hits *hits)
{
    return batch_of(s, LC_SHAPE_SPHERE, 0, 1, centers, NULL, radii, n, LOCD_HIT_ALL, filter, hits);
}

locd_status locd_scene_overlap_sphere_batch_f64(const locd_scene *s, const double *centers, const double *radii,
                                                size_t n, const locd_query_filter *filter, locd_hits *hits)
{
    return batch_of(s, LC_SHAPE_SPHERE, 0, 0, centers, NULL, radii, n, LOCD_HIT_ALL, filter, hits);
}
