/* The scene's queries (docs/queries.md) against a brute force over a model
 * of the scene, in every state: after updates, between a move and its
 * update, after removals and adds; every kind (box, point, sphere, ray, box
 * cast) and mode (all, closest, any), with masks and a reject callback; the
 * batches against the same queries one by one, for 1, 2 and 3 threads;
 * hand-made hard cases; bad input; allocation failures. */
#include <locd/scene.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fail_alloc.h"
#include "runner.h"
#include "support.h"

/* ---- the model and its brute force (the documented float64 tests) ---- */

typedef struct obj {
    locd_id id;
    double box[6];
    uint64_t cat, user;
} obj;

typedef struct model {
    obj *o;
    size_t n, cap;
} model;

static void m_put(model *m, locd_id id, const double *b, uint64_t cat, uint64_t user)
{
    if (m->n == m->cap) {
        m->cap = m->cap ? 2 * m->cap : 1024;
        m->o = realloc(m->o, m->cap * sizeof *m->o);
        TEST_ASSERT_NOT_NULL(m->o);
    }
    m->o[m->n].id = id, m->o[m->n].cat = cat, m->o[m->n].user = user;
    memcpy(m->o[m->n].box, b, 6 * sizeof(double));
    m->n++;
}

static void m_drop(model *m, size_t k)
{
    m->o[k] = m->o[--m->n];
}

typedef struct query {
    int kind; /* 0 box, 1 point, 2 sphere, 3 ray, 4 box cast */
    double v[6], d[3], num;
    uint32_t mode;
} query;

static int bf_box(const double *q, const double *b)
{
    return b[0] <= q[3] && q[0] <= b[3] && b[1] <= q[4] && q[1] <= b[4] && b[2] <= q[5] && q[2] <= b[5];
}

static double gap(double c, double lo, double hi)
{
    return c < lo ? lo - c : c > hi ? c - hi : 0.0;
}

static int bf_sphere(const double *c, double r, const double *b)
{
    const double dx = gap(c[0], b[0], b[3]), dy = gap(c[1], b[1], b[4]), dz = gap(c[2], b[2], b[5]);
    return (dx * dx + dy * dy) + dz * dz <= r * r;
}

/* The box lo..hi moved by t d meets b: its entry time. */
static int bf_cast(const double *lo, const double *hi, const double *d, double max_t, const double *b, double *t)
{
    double t0 = 0.0, t1 = max_t;
    int a;
    for (a = 0; a < 3; a++) {
        const double in = b[a] - hi[a], out = b[a + 3] - lo[a];
        if (d[a] == 0.0) {
            if (in > 0.0 || out < 0.0)
                return 0;
            continue;
        }
        {
            const double u = (d[a] > 0.0 ? in : out) / d[a], v = (d[a] > 0.0 ? out : in) / d[a];
            t0 = u > t0 ? u : t0;
            t1 = v < t1 ? v : t1;
        }
        if (t0 > t1)
            return 0;
    }
    *t = t0;
    return 1;
}

typedef struct hit {
    double t;
    locd_id id;
} hit;

static int cmp_hit(const void *pa, const void *pb)
{
    const hit *a = pa, *b = pb;
    if (a->t != b->t)
        return a->t < b->t ? -1 : 1;
    return (a->id > b->id) - (a->id < b->id);
}

/* The reject callback of the tests: objects whose user value is odd. */
static int reject_odd(void *user, locd_id id, uint64_t user_value)
{
    (void)id;
    ++*(long *)user;
    return (int)(user_value & 1u);
}

/* Every hit of q in the model, sorted by (t, id). */
static hit *bf_all(const model *m, const query *q, uint64_t mask, int reject, size_t *n)
{
    hit *h = malloc((m->n + 1) * sizeof *h);
    size_t k, w = 0;
    TEST_ASSERT_NOT_NULL(h);
    for (k = 0; k < m->n; k++) {
        const double *b = m->o[k].box;
        double t = 0.0, p[6];
        int in;
        if (!(m->o[k].cat & mask) || (reject && (m->o[k].user & 1u)))
            continue;
        switch (q->kind) {
        case 0: in = bf_box(q->v, b); break;
        case 1: memcpy(p, q->v, 3 * sizeof *p), memcpy(p + 3, q->v, 3 * sizeof *p), in = bf_box(p, b); break;
        case 2: in = bf_sphere(q->v, q->num, b); break;
        case 3: in = bf_cast(q->v, q->v, q->d, q->num, b, &t); break;
        default: in = bf_cast(q->v, q->v + 3, q->d, q->num, b, &t); break;
        }
        if (in)
            h[w].t = t, h[w++].id = m->o[k].id;
    }
    qsort(h, w, sizeof *h, cmp_hit);
    *n = w;
    return h;
}

/* ---- the scene's answer, one query ---- */

static locd_status ask(const locd_scene *s, const query *q, const locd_query_filter *f, locd_id *ids, double *t,
                       size_t cap, size_t *n)
{
    switch (q->kind) {
    case 0: return locd_scene_overlap_box_f64(s, q->v, f, ids, cap, n);
    case 1: return locd_scene_overlap_point_f64(s, q->v, f, ids, cap, n);
    case 2: return locd_scene_overlap_sphere_f64(s, q->v, q->num, f, ids, cap, n);
    case 3: return locd_scene_cast_ray_f64(s, q->v, q->d, q->num, q->mode, f, ids, t, cap, n);
    default: return locd_scene_cast_box_f64(s, q->v, q->d, q->num, q->mode, f, ids, t, cap, n);
    }
}

/* q on the scene equals the brute force: every hit in order; the closest
 * the first of them; any one of them (none when there is none). */
static void check_query(const locd_scene *s, const model *m, const query *q, uint64_t mask, int reject)
{
    size_t nb, n, k, cap = m->n + 1;
    hit *want = bf_all(m, q, mask, reject, &nb);
    locd_id *ids = malloc(cap * sizeof *ids);
    double *t = malloc(cap * sizeof *t);
    locd_query_filter f;
    long calls = 0;
    locd_query_filter_init(&f);
    f.mask = mask;
    if (reject)
        f.reject = reject_odd, f.user = &calls;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, ask(s, q, &f, ids, t, cap, &n));
    if (q->kind < 3 || q->mode == LOCD_HIT_ALL) {
        if (n != nb)
            LT_FAIL("query kind %d mode %u: %zu hits, brute force %zu", q->kind, q->mode, n, nb);
        for (k = 0; k < n; k++) {
            const locd_id want_id = want[k].id;
            if (q->kind < 3) { /* ids ascending */
                TEST_ASSERT_TRUE(k == 0 || ids[k] > ids[k - 1]);
                continue;
            }
            if (ids[k] != want_id || t[k] != want[k].t)
                LT_FAIL("query kind %d: hit %zu is (%g, %llu), brute force (%g, %llu)", q->kind, k, t[k],
                        (unsigned long long)ids[k], want[k].t, (unsigned long long)want_id);
        }
        if (q->kind < 3) { /* the same set */
            qsort(want, nb, sizeof *want, cmp_hit); /* (t 0: by id) */
            for (k = 0; k < n; k++)
                TEST_ASSERT_EQUAL_UINT64(want[k].id, ids[k]);
        }
    } else if (q->mode == LOCD_HIT_CLOSEST) {
        TEST_ASSERT_EQUAL_size_t(nb ? 1 : 0, n);
        if (n && (ids[0] != want[0].id || t[0] != want[0].t))
            LT_FAIL("closest is (%g, %llu), brute force (%g, %llu)", t[0], (unsigned long long)ids[0], want[0].t,
                    (unsigned long long)want[0].id);
    } else {
        TEST_ASSERT_EQUAL_size_t(nb ? 1 : 0, n);
        for (k = 0; n && k < nb && !(want[k].id == ids[0] && want[k].t == t[0]); k++)
            ;
        if (n && k == nb)
            LT_FAIL("any hit (%g, %llu) is not a hit", t[0], (unsigned long long)ids[0]);
    }
    free(want), free(ids), free(t);
}

/* ---- random scenes and queries ---- */

static void random_box(ts_rng *r, double scale, double *b)
{
    const double e = (ts_uniform(r) < 0.02 ? 3.0 : 0.4) * ts_uniform(r);
    int a;
    for (a = 0; a < 3; a++) {
        b[a] = scale * ts_uniform(r);
        b[a + 3] = b[a] + (ts_uniform(r) < 0.1 ? 0.0 : e);
    }
}

static void random_query(ts_rng *r, int kind, double scale, query *q)
{
    int a;
    memset(q, 0, sizeof *q);
    q->kind = kind;
    q->mode = (uint32_t)(ts_next(r) % 3);
    for (a = 0; a < 3; a++) {
        q->v[a] = scale * (1.2 * ts_uniform(r) - 0.1);
        q->v[a + 3] = q->v[a] + (kind == 0 || kind == 4 ? 1.5 * ts_uniform(r) : 0.0);
        q->d[a] = ts_uniform(r) < 0.15 ? 0.0 : scale * (ts_uniform(r) - 0.5);
    }
    q->num = kind == 2 ? 2.0 * ts_uniform(r) : ts_uniform(r) < 0.1 ? INFINITY : 1.5 * ts_uniform(r);
}

static locd_engine *new_engine(uint32_t threads, const locd_allocator *alloc)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_engine_config_init(&cfg);
    cfg.threads = threads;
    if (alloc)
        cfg.allocator = *alloc;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_create(&cfg, &e));
    return e;
}

/* n random objects added to s and m; their categories 1, 2 or 4, user values k. */
static void add_random(locd_scene *s, model *m, ts_rng *r, size_t n, double scale, int f32)
{
    double *b = malloc(6 * n * sizeof *b);
    float *fb = malloc(6 * n * sizeof *fb);
    uint64_t *cat = malloc(n * sizeof *cat), *user = malloc(n * sizeof *user);
    locd_id *ids = malloc(n * sizeof *ids);
    locd_scene_add_options o;
    size_t k;
    for (k = 0; k < n; k++) {
        random_box(r, scale, b + 6 * k);
        cat[k] = (uint64_t)1 << (ts_next(r) % 3), user[k] = ts_next(r) % 1000;
    }
    for (k = 0; k < 6 * n; k++) /* floats: the model keeps what the scene keeps */
        fb[k] = (float)b[k], b[k] = f32 ? (double)fb[k] : b[k];
    locd_scene_add_options_init(&o);
    o.categories = cat, o.users = user;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, f32 ? locd_scene_add_f32(s, fb, n, &o, ids) : locd_scene_add_f64(s, b, n, &o, ids));
    for (k = 0; k < n; k++)
        m_put(m, ids[k], b + 6 * k, cat[k], user[k]);
    free(b), free(fb), free(cat), free(user), free(ids);
}

/* A share of the objects moved (a little, or far), as doubles. */
static void move_random(locd_scene *s, model *m, ts_rng *r, double share, double step)
{
    locd_id *ids = malloc((m->n + 1) * sizeof *ids);
    double *b = malloc(6 * (m->n + 1) * sizeof *b);
    size_t k, n = 0;
    int a;
    for (k = 0; k < m->n; k++)
        if (ts_uniform(r) < share) {
            for (a = 0; a < 3; a++) {
                const double dx = step * (ts_uniform(r) - 0.5);
                m->o[k].box[a] += dx, m->o[k].box[a + 3] += dx;
            }
            ids[n] = m->o[k].id;
            memcpy(b + 6 * n++, m->o[k].box, 6 * sizeof *b);
        }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, ids, b, n));
    free(ids), free(b);
}

static void remove_random(locd_scene *s, model *m, ts_rng *r, size_t n)
{
    locd_id ids[64];
    size_t k;
    for (k = 0; k < n && k < 64 && m->n; k++) {
        const size_t at = (size_t)(ts_next(r) % m->n);
        ids[k] = m->o[at].id;
        m_drop(m, at);
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, ids, k));
}

static void check_random_queries(const locd_scene *s, const model *m, ts_rng *r, int rounds, double scale)
{
    int k, kind;
    for (k = 0; k < rounds; k++)
        for (kind = 0; kind < 5; kind++) {
            query q;
            random_query(r, kind, scale, &q);
            check_query(s, m, &q, ts_uniform(r) < 0.3 ? 3u : ~(uint64_t)0, ts_uniform(r) < 0.3);
        }
}

/* Long random sequences: queries after every kind of change, updated or not. */
static void queries_follow_the_scene(void)
{
    int f32;
    for (f32 = 0; f32 < 2; f32++) {
        locd_engine *e = new_engine(2, NULL);
        locd_scene *s;
        model m;
        ts_rng r;
        int step;
        memset(&m, 0, sizeof m);
        ts_seed(&r, 77 + (uint64_t)f32);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
        check_random_queries(s, &m, &r, 2, 10.0); /* empty */
        add_random(s, &m, &r, 3000, 10.0, f32);
        check_random_queries(s, &m, &r, 4, 10.0); /* before the first update */
        for (step = 0; step < 120; step++) {
            const double op = ts_uniform(&r);
            if (op < 0.5)
                move_random(s, &m, &r, op < 0.1 ? 1.0 : 0.05, op < 0.05 ? 8.0 : 0.2);
            else if (op < 0.7)
                add_random(s, &m, &r, 1 + ts_next(&r) % 40, 10.0, f32);
            else if (op < 0.85)
                remove_random(s, &m, &r, 1 + ts_next(&r) % 40);
            if (ts_uniform(&r) < 0.6)
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS));
            check_random_queries(s, &m, &r, 2, 10.0);
        }
        locd_scene_destroy(s);
        locd_engine_destroy(e);
        free(m.o);
    }
}

/* ---- batches ---- */

/* A batch of n random queries of one kind, on a scene of `threads`. */
static void run_batch(const locd_scene *s, int kind, uint32_t mode, const query *q, size_t n, locd_hits *h)
{
    double *v = malloc(6 * n * sizeof *v), *d = malloc(3 * n * sizeof *d), *num = malloc(n * sizeof *num);
    const int w = kind == 0 || kind == 4 ? 6 : 3;
    size_t k;
    locd_status st;
    for (k = 0; k < n; k++) {
        memcpy(v + (size_t)w * k, q[k].v, (size_t)w * sizeof *v);
        memcpy(d + 3 * k, q[k].d, 3 * sizeof *d);
        num[k] = q[k].num;
    }
    switch (kind) {
    case 0: st = locd_scene_overlap_box_batch_f64(s, v, n, NULL, h); break;
    case 1: st = locd_scene_overlap_point_batch_f64(s, v, n, NULL, h); break;
    case 2: st = locd_scene_overlap_sphere_batch_f64(s, v, num, n, NULL, h); break;
    case 3: st = locd_scene_cast_ray_batch_f64(s, v, d, num, n, mode, NULL, h); break;
    default: st = locd_scene_cast_box_batch_f64(s, v, d, num, n, mode, NULL, h); break;
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, st);
    free(v), free(d), free(num);
}

/* The batch equals the queries one by one. */
static void same_as_one_by_one(const locd_scene *s, const query *q, size_t n, uint32_t mode, const locd_hits *h)
{
    const uint64_t *off = locd_hits_offsets(h);
    const locd_id *ids = locd_hits_ids(h);
    const double *t = locd_hits_t(h);
    locd_id one[4096];
    double tt[4096];
    size_t k, c, j;
    TEST_ASSERT_EQUAL_size_t(n, locd_hits_queries(h));
    for (k = 0; k < n; k++) {
        query qk = q[k];
        qk.mode = mode;
        TEST_ASSERT_EQUAL_INT(LOCD_OK, ask(s, &qk, NULL, one, tt, 4096, &c));
        if (qk.kind >= 3 && mode != LOCD_HIT_ALL) {
            TEST_ASSERT_EQUAL_UINT64(off[k], k);
            TEST_ASSERT_EQUAL_UINT64(c ? one[0] : LOCD_ID_NONE, ids[k]);
            TEST_ASSERT_TRUE(c ? tt[0] == t[k] : isinf(t[k]));
            continue;
        }
        TEST_ASSERT_EQUAL_UINT64(c, off[k + 1] - off[k]);
        for (j = 0; j < c; j++) {
            TEST_ASSERT_EQUAL_UINT64(one[j], ids[off[k] + j]);
            if (qk.kind >= 3)
                TEST_ASSERT_TRUE(tt[j] == t[off[k] + j]);
        }
    }
}

/* Batches of 1, 2 and 3 threads on scenes made alike give the same bytes,
 * and the queries one by one. */
static void batches_match_one_by_one(void)
{
    enum { N = 20000, Q = 600 };
    locd_engine *e[3];
    locd_scene *s[3];
    locd_hits *h[3];
    query *q = malloc(Q * sizeof *q);
    int kind, i;
    uint32_t mode;
    for (i = 0; i < 3; i++) {
        model m;
        ts_rng r;
        memset(&m, 0, sizeof m);
        ts_seed(&r, 5);
        e[i] = new_engine((uint32_t)i + 1, NULL);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e[i], NULL, &s[i]));
        add_random(s[i], &m, &r, N, 30.0, 1);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s[i], 0));
        move_random(s[i], &m, &r, 0.02, 0.3); /* a move not updated yet */
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_hits_create(NULL, &h[i]));
        free(m.o);
    }
    for (kind = 0; kind < 5; kind++)
        for (mode = 0; mode < (kind >= 3 ? 3u : 1u); mode++) {
            ts_rng r;
            size_t k;
            ts_seed(&r, 100 + (uint64_t)kind);
            for (k = 0; k < Q; k++)
                random_query(&r, kind, 30.0, &q[k]);
            for (i = 0; i < 3; i++)
                run_batch(s[i], kind, mode, q, Q, h[i]);
            same_as_one_by_one(s[0], q, Q, mode, h[0]);
            for (i = 1; i < 3; i++) {
                TEST_ASSERT_EQUAL_size_t(locd_hits_count(h[0]), locd_hits_count(h[i]));
                LT_ASSERT_EQUAL_MEMORY(locd_hits_offsets(h[0]), locd_hits_offsets(h[i]), (Q + 1) * sizeof(uint64_t));
                LT_ASSERT_EQUAL_MEMORY(locd_hits_ids(h[0]), locd_hits_ids(h[i]), locd_hits_count(h[0]) * sizeof(locd_id));
                if (kind >= 3)
                    LT_ASSERT_EQUAL_MEMORY(locd_hits_t(h[0]), locd_hits_t(h[i]), locd_hits_count(h[0]) * sizeof(double));
            }
        }
    for (i = 0; i < 3; i++) {
        locd_hits_destroy(h[i]);
        locd_scene_destroy(s[i]);
        locd_engine_destroy(e[i]);
    }
    free(q);
}

/* ---- hard cases ---- */

/* Boxes on a lattice, touching; zero-size boxes; a box far from the origin. */
static void hard_cases(void)
{
    locd_engine *e = new_engine(1, NULL);
    locd_scene *s;
    model m;
    double b[6];
    locd_id id;
    int x, y, z, k;
    static const double far_off = 1e7;
    memset(&m, 0, sizeof m);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    for (x = 0; x < 6; x++)
        for (y = 0; y < 6; y++)
            for (z = 0; z < 3; z++) {
                const double o[3] = {x, y, z};
                for (k = 0; k < 3; k++)
                    b[k] = o[k], b[k + 3] = o[k] + 1.0;
                if ((x + y + z) % 5 == 0) /* a point on a corner */
                    b[3] = b[0], b[4] = b[1], b[5] = b[2];
                {
                    const uint64_t user = (uint64_t)(x + y);
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, 1, NULL, &id));
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_user(s, &id, 1, &user));
                    m_put(&m, id, b, 1, user);
                }
            }
    for (k = 0; k < 3; k++)
        b[k] = far_off, b[k + 3] = far_off + 0.5;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, 1, NULL, &id));
    m_put(&m, id, b, 1, 0);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, 0));
    {
        /* rays along faces and edges, through corners, zero and huge
           directions, max_t 0 and inf; boxes and spheres touching faces */
        static const double cases[][8] = {
            {0, 0, 0, 1, 0, 0, 10, 3},   {0, 1, 1, 1, 0, 0, 10, 3},   {1, 1, 1, 1, 1, 1, 10, 3},
            {2, 2, 2, 0, 0, 0, 10, 3},   {2, 2, 2, 1e30, 0, 0, 1, 3}, {0.5, 0.5, -5, 0, 0, 1, 0, 3},
            {0.5, 0.5, -5, 0, 0, 1, INFINITY, 3}, {-1, 3, 1, 1, 0, 0, INFINITY, 3}, {6, 6, 3, -1, -1, -1, 20, 3},
            {3, 3, 1, 0, 0, 0, 0, 1},    {2, 2, 2, 0, 0, 0, 0, 1},    {0, 0, 0, 0, 0, 0, 0, 1},
            {2, 2, 1, 1, 1, 1, 0, 2},    {2.5, 2.5, 1.5, 0, 0, 0, 0.5, 2},
            {1e7, 1e7, 1e7 - 1, 0, 0, 1, 1, 3},
            {0.5, 0.5, -5, 0, 0, 1e-310, INFINITY, 3}, /* every entry time overflows to +inf: still hits */
            {2, 2, 2, 0, 0, 0, 1e300, 2}, {2, 2, 2, 0, 0, 0, INFINITY, 2}, /* r*r overflows: every object */
        };
        size_t c;
        uint32_t mode;
        for (c = 0; c < sizeof cases / sizeof cases[0]; c++)
            for (mode = 0; mode < 3; mode++) {
                query q;
                memset(&q, 0, sizeof q);
                q.kind = (int)cases[c][7];
                memcpy(q.v, cases[c], 3 * sizeof(double));
                memcpy(q.d, cases[c] + 3, 3 * sizeof(double));
                q.num = cases[c][6];
                q.mode = mode;
                if (q.kind == 1) /* a box from the point and the vector as its corner */
                    q.kind = 0, memcpy(q.v + 3, q.v, 3 * sizeof(double)), q.v[3] += q.d[0], q.v[4] += q.d[1],
                    q.v[5] += q.d[2];
                check_query(s, &m, &q, ~(uint64_t)0, 0);
                check_query(s, &m, &q, ~(uint64_t)0, 1);
                q.kind = 4; /* the same as a cast of the unit box from there */
                memcpy(q.v + 3, q.v, 3 * sizeof(double));
                q.v[3] += 1.0, q.v[4] += 1.0, q.v[5] += 1.0;
                if (!isinf(q.d[0]) && fabs(q.d[0]) < 1e20)
                    check_query(s, &m, &q, ~(uint64_t)0, 0);
            }
    }
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o);
}

/* ---- grazing queries at every scale ---- */

/* A corner of box b: bit a of `which` picks max on axis a. */
static void corner(const double *b, unsigned which, double *p)
{
    int a;
    for (a = 0; a < 3; a++)
        p[a] = b[a + 3 * (int)((which >> a) & 1u)];
}

/* One query that grazes object j of m (its kind from `kind`): a ray ending
 * on a corner, a ray along a face, a box cast whose corner reaches the
 * object's, a sphere through a corner, a box touching a face. The tree's
 * node tests in floats must never drop such a hit (the brute force decides
 * whether it is one). */
static void grazing_query(ts_rng *r, const model *m, double lo, double span, int kind, query *q)
{
    const double *b = m->o[ts_next(r) % m->n].box;
    double p[3], o[3];
    int a;
    memset(q, 0, sizeof *q);
    q->mode = (uint32_t)(ts_next(r) % 3);
    corner(b, (unsigned)(ts_next(r) % 8), p);
    for (a = 0; a < 3; a++)
        o[a] = lo + span * ts_uniform(r);
    switch (kind) {
    case 0: /* a ray that ends on the corner */
        q->kind = 3, q->num = 1.0;
        for (a = 0; a < 3; a++)
            q->v[a] = o[a], q->d[a] = p[a] - o[a];
        break;
    case 1: /* a ray in the plane of a face */
        a = (int)(ts_next(r) % 3);
        q->kind = 3, q->num = ts_uniform(r) < 0.2 ? INFINITY : 2.0;
        memcpy(q->v, o, sizeof o);
        q->v[a] = p[a];
        for (a = 0; a < 3; a++)
            q->d[a] = q->v[a] == p[a] ? 0.0 : p[a] - q->v[a];
        break;
    case 2: /* a box cast whose max corner reaches the corner at t = 1 */
        q->kind = 4, q->num = 1.0;
        for (a = 0; a < 3; a++) {
            const double h = 0.01 * span * ts_uniform(r);
            q->v[a] = o[a] - h, q->v[a + 3] = o[a];
            q->d[a] = p[a] - o[a];
        }
        break;
    case 3: /* a sphere whose radius is the distance to the corner */
        q->kind = 2;
        memcpy(q->v, o, sizeof o);
        q->num = sqrt((o[0] - p[0]) * (o[0] - p[0]) + (o[1] - p[1]) * (o[1] - p[1]) + (o[2] - p[2]) * (o[2] - p[2]));
        break;
    default: /* a box whose min corner is the corner */
        q->kind = 0;
        for (a = 0; a < 3; a++)
            q->v[a] = p[a], q->v[a + 3] = p[a] + 0.05 * span * ts_uniform(r);
        break;
    }
}

/* Scenes from 1e-300 to 1e300 wide, near the origin and far from it, as
 * doubles and (where floats hold them) as floats; queries that graze
 * their objects. The node tests' slack and their ranges (queries.md). */
static void grazing_queries_at_every_scale(void)
{
    static const double scales[] = {1e-300, 1e-40, 1e-20, 1e-3, 1.0, 3e6, 1e18, 1e30, 1e36, 1e100, 1e300};
    size_t i;
    int f32, far, k, kind;
    for (i = 0; i < sizeof scales / sizeof scales[0]; i++)
        for (far = 0; far < 2; far++)
            for (f32 = 0; f32 < 2; f32++) {
                const double span = scales[i] / (far ? 1024.0 : 1.0), lo = far ? scales[i] : 0.0;
                locd_engine *e;
                locd_scene *s;
                model m;
                ts_rng r;
                if (f32 && (lo + 2 * span > 1e38 || span < 1e-37))
                    continue;
                e = new_engine(1, NULL);
                memset(&m, 0, sizeof m);
                ts_seed(&r, 1000 + 4 * i + 2 * (size_t)far + (size_t)f32);
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
                {
                    double b[6 * 300];
                    float fb[6 * 300];
                    locd_id ids[300];
                    int a;
                    for (k = 0; k < 300; k++)
                        for (a = 0; a < 3; a++) {
                            b[6 * k + a] = lo + span * ts_uniform(&r);
                            b[6 * k + a + 3] = b[6 * k + a] + (k % 7 == 0 ? 0.0 : 0.05 * span * ts_uniform(&r));
                        }
                    for (k = 0; k < 6 * 300; k++)
                        fb[k] = (float)b[k], b[k] = f32 ? (double)fb[k] : b[k];
                    for (k = 0; k < 300; k++) /* (floats may round min above max: make them a point) */
                        for (a = 0; a < 3; a++)
                            if (b[6 * k + a] > b[6 * k + a + 3])
                                b[6 * k + a + 3] = b[6 * k + a], fb[6 * k + a + 3] = fb[6 * k + a];
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, f32 ? locd_scene_add_f32(s, fb, 300, NULL, ids)
                                                       : locd_scene_add_f64(s, b, 300, NULL, ids));
                    for (k = 0; k < 300; k++)
                        m_put(&m, ids[k], b + 6 * k, 1, (uint64_t)k);
                }
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, 0));
                for (k = 0; k < 60; k++)
                    for (kind = 0; kind < 5; kind++) {
                        query q;
                        grazing_query(&r, &m, lo, span, kind, &q);
                        check_query(s, &m, &q, ~(uint64_t)0, 0);
                    }
                locd_scene_destroy(s);
                locd_engine_destroy(e);
                free(m.o);
            }
}

/* ---- bad input ---- */

static void bad_queries_fail_and_change_nothing(void)
{
    locd_engine *e = new_engine(2, NULL);
    locd_scene *s;
    locd_hits *h;
    model m;
    ts_rng r;
    locd_id ids[8];
    double t[8], o[6] = {1, 1, 1, 2, 2, 2}, d[3] = {1, 0, 0}, bad[6], maxt[4] = {1, 1, 1, 1};
    double many[4 * 6], dirs[4 * 3];
    size_t n = 99, k;
    const double nan = NAN;
    memset(&m, 0, sizeof m);
    ts_seed(&r, 9);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    add_random(s, &m, &r, 200, 5.0, 0);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, 0));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_hits_create(NULL, &h));
    memcpy(bad, o, sizeof bad);
    bad[1] = nan;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_NONFINITE, locd_scene_cast_ray_f64(s, bad, d, 1, 0, NULL, ids, t, 8, &n));
    bad[1] = INFINITY;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_NONFINITE, locd_scene_cast_ray_f64(s, bad, d, 1, 0, NULL, ids, t, 8, &n));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_NONFINITE, locd_scene_cast_ray_f64(s, o, bad + 1, 1, 0, NULL, ids, t, 8, &n));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVALID_ARGUMENT, locd_scene_cast_ray_f64(s, o, d, -1, 0, NULL, ids, t, 8, &n));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVALID_ARGUMENT, locd_scene_cast_ray_f64(s, o, d, nan, 0, NULL, ids, t, 8, &n));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVALID_ARGUMENT, locd_scene_cast_ray_f64(s, o, d, 1, 7, NULL, ids, t, 8, &n));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVALID_ARGUMENT, locd_scene_overlap_sphere_f64(s, o, -1, NULL, ids, 8, &n));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVALID_ARGUMENT, locd_scene_overlap_sphere_f64(s, o, nan, NULL, ids, 8, &n));
    memcpy(bad, o, sizeof bad);
    bad[0] = 3; /* min > max */
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVERTED_BOX, locd_scene_overlap_box_f64(s, bad, NULL, ids, 8, &n));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVERTED_BOX, locd_scene_cast_box_f64(s, bad, d, 1, 0, NULL, ids, t, 8, &n));
    /* a batch names the bad query and leaves the hits empty */
    for (k = 0; k < 4; k++)
        memcpy(many + 6 * k, o, 6 * sizeof(double)), memcpy(dirs + 3 * k, d, 3 * sizeof(double));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_cast_box_batch_f64(s, many, dirs, maxt, 4, LOCD_HIT_ALL, NULL, h));
    TEST_ASSERT_EQUAL_size_t(4, locd_hits_queries(h));
    many[6 * 2 + 4] = nan;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_NONFINITE, locd_scene_cast_box_batch_f64(s, many, dirs, maxt, 4, 0, NULL, h));
    TEST_ASSERT_EQUAL_INT64(2, locd_last_error_index());
    TEST_ASSERT_EQUAL_size_t(0, locd_hits_queries(h));
    TEST_ASSERT_EQUAL_size_t(0, locd_hits_count(h));
    many[6 * 2 + 4] = 2;
    maxt[3] = -0.5;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVALID_ARGUMENT, locd_scene_cast_ray_batch_f64(s, many, dirs, maxt, 4, 0, NULL, h));
    TEST_ASSERT_EQUAL_INT64(3, locd_last_error_index());
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_NULL_POINTER, locd_scene_overlap_sphere_batch_f64(s, many, NULL, 4, NULL, h));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_NULL_POINTER, locd_scene_overlap_box_batch_f64(s, many, 1, NULL, NULL));
    /* a filter of an unknown size */
    {
        locd_query_filter f;
        locd_query_filter_init(&f);
        f.size = 4;
        TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVALID_ARGUMENT, locd_scene_overlap_box_f64(s, o, &f, ids, 8, &n));
    }
    /* nothing changed: the queries still answer as the brute force */
    check_random_queries(s, &m, &r, 5, 5.0);
    locd_hits_destroy(h);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o);
}

/* ---- allocation failures ---- */

/* A query that cannot allocate fails with LOCD_ERR_NO_MEMORY or answers
 * exactly; the next ones answer exactly. */
static void allocation_failures(void)
{
    locd_engine *e = new_engine(2, fa_allocator());
    locd_scene *s;
    locd_hits *h;
    model m;
    ts_rng r;
    uint64_t k;
    int failed = 0;
    memset(&m, 0, sizeof m);
    ts_seed(&r, 3);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    add_random(s, &m, &r, 2000, 10.0, 1);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, 0));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_hits_create(fa_allocator(), &h));
    for (k = 1; k < 40; k++) {
        query q[300];
        fa_counts c;
        locd_status st;
        size_t i;
        move_random(s, &m, &r, 0.05, 0.3); /* the next query syncs the tree */
        for (i = 0; i < 300; i++)
            random_query(&r, 3, 10.0, &q[i]);
        fa_arm(k, 0);
        {
            double v[300 * 3], d[300 * 3], mt[300];
            for (i = 0; i < 300; i++)
                memcpy(v + 3 * i, q[i].v, 24), memcpy(d + 3 * i, q[i].d, 24), mt[i] = q[i].num;
            st = locd_scene_cast_ray_batch_f64(s, v, d, mt, 300, LOCD_HIT_ALL, NULL, h);
        }
        fa_counts_get(&c);
        fa_arm(0, 0);
        if (st != LOCD_OK) {
            TEST_ASSERT_EQUAL_INT(LOCD_ERR_NO_MEMORY, st);
            TEST_ASSERT_EQUAL_size_t(0, locd_hits_queries(h));
            failed++;
        } else {
            same_as_one_by_one(s, q, 300, LOCD_HIT_ALL, h);
        }
        check_random_queries(s, &m, &r, 1, 10.0);
        if (c.failures == 0)
            break;
    }
    LT_PRINT("query allocation failures: %d batches failed cleanly\n", failed);
    TEST_ASSERT_TRUE(failed > 0);
    locd_hits_destroy(h);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o);
    {
        fa_counts c;
        fa_counts_get(&c);
        TEST_ASSERT_EQUAL_UINT64(0, c.bad_frees);
    }
}

static const lt_test tests[] = {
    LT_TEST(queries_follow_the_scene),
    LT_TEST(batches_match_one_by_one),
    LT_TEST(hard_cases),
    LT_TEST(grazing_queries_at_every_scale),
    LT_TEST(bad_queries_fail_and_change_nothing),
    LT_TEST(allocation_failures),
};

int main(void)
{
    return LT_RUN(tests);
}
