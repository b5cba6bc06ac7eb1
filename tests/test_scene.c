/* The persistent scene (include/locd/scene.h) against a brute-force model
 * written here: long random sequences of add, move, remove, set_filter and
 * set_user, with static objects, compared at every update (pairs, created,
 * lost) and with box, point and ray queries; bad batches rejected with the
 * right index and nothing changed; allocation failures; thread counts. */
#include <locd/scene.h>
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "fail_alloc.h"
#include "support.h"

/* ---- the model ---- */
typedef struct m_obj {
    locd_id id;
    double box[6];
    uint64_t cat, mask, group, user;
    int stat;
} m_obj;

typedef struct model {
    m_obj *o;
    size_t n, cap;
    locd_id *pairs; /* rows of the last update, sorted */
    size_t npairs;
} model;

static void m_add(model *m, locd_id id, const double *box, uint64_t cat, uint64_t mask, uint64_t group,
                  uint64_t user, int stat)
{
    if (m->n == m->cap) {
        m->cap = m->cap ? 2 * m->cap : 64;
        m->o = realloc(m->o, m->cap * sizeof *m->o);
    }
    m->o[m->n].id = id;
    memcpy(m->o[m->n].box, box, sizeof m->o[m->n].box);
    m->o[m->n].cat = cat, m->o[m->n].mask = mask, m->o[m->n].group = group, m->o[m->n].user = user;
    m->o[m->n].stat = stat;
    m->n++;
}

static m_obj *m_find(model *m, locd_id id)
{
    size_t k;
    for (k = 0; k < m->n; k++)
        if (m->o[k].id == id)
            return &m->o[k];
    return NULL;
}

static void m_remove(model *m, locd_id id)
{
    m_obj *o = m_find(m, id);
    TEST_ASSERT_NOT_NULL(o);
    *o = m->o[--m->n];
}

static int overlap(const double *a, const double *b)
{
    return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

static int may_pair(const m_obj *a, const m_obj *b)
{
    if (a->stat && b->stat)
        return 0;
    if (!(a->cat & b->mask) || !(b->cat & a->mask))
        return 0;
    if (a->group == b->group && a->group != 0)
        return 0;
    return overlap(a->box, b->box);
}

static int cmp_row(const void *pa, const void *pb)
{
    const locd_id *a = pa, *b = pb;
    if (a[0] != b[0])
        return a[0] < b[0] ? -1 : 1;
    return (a[1] > b[1]) - (a[1] < b[1]);
}

static locd_id *m_pairs(const model *m, size_t *count)
{
    size_t i, j, w = 0, cap = 64;
    locd_id *r = malloc(cap * 2 * sizeof *r);
    for (i = 0; i < m->n; i++)
        for (j = i + 1; j < m->n; j++)
            if (may_pair(&m->o[i], &m->o[j])) {
                if (w == cap)
                    cap *= 2, r = realloc(r, cap * 2 * sizeof *r);
                r[2 * w] = m->o[i].id < m->o[j].id ? m->o[i].id : m->o[j].id;
                r[2 * w + 1] = m->o[i].id < m->o[j].id ? m->o[j].id : m->o[i].id;
                w++;
            }
    qsort(r, w, 2 * sizeof *r, cmp_row);
    *count = w;
    return r;
}

/* Rows of a not in b (both sorted). */
static locd_id *minus(const locd_id *a, size_t na, const locd_id *b, size_t nb, size_t *count)
{
    size_t i, j = 0, w = 0;
    locd_id *r = malloc((na ? na : 1) * 2 * sizeof *r);
    for (i = 0; i < na; i++) {
        while (j < nb && cmp_row(b + 2 * j, a + 2 * i) < 0)
            j++;
        if (j < nb && cmp_row(b + 2 * j, a + 2 * i) == 0)
            continue;
        r[2 * w] = a[2 * i], r[2 * w + 1] = a[2 * i + 1], w++;
    }
    *count = w;
    return r;
}

static void same_rows(const char *what, const locd_id *want, size_t nwant, const locd_id *got, size_t ngot)
{
    size_t k;
    if (nwant != ngot)
        LT_FAIL("%s: %zu rows, expected %zu", what, ngot, nwant);
    for (k = 0; k < nwant; k++)
        if (want[2 * k] != got[2 * k] || want[2 * k + 1] != got[2 * k + 1])
            LT_FAIL("%s: row %zu is (%llx, %llx), expected (%llx, %llx)", what, k, (unsigned long long)got[2 * k],
                    (unsigned long long)got[2 * k + 1], (unsigned long long)want[2 * k],
                    (unsigned long long)want[2 * k + 1]);
}

static unsigned g_updates, g_incremental;

/* LOCD_TEST_HEAVY=0 (the sanitizer runs) shortens the sequences. */
static int steps(int n)
{
    const char *v = getenv("LOCD_TEST_HEAVY");
    return v && v[0] == '0' ? (n + 9) / 10 : n;
}

/* Checks the lists of the update just made (pairs, created and lost)
 * against the model, and moves the model's previous set on. */
static void check_lists(locd_scene *s, model *m)
{
    const locd_id *p;
    size_t np, nw, nc, nl;
    locd_id *want = m_pairs(m, &nw), *cr, *lo;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s, &p, &np));
    same_rows("pairs", want, nw, p, np);
    cr = minus(want, nw, m->pairs, m->npairs, &nc);
    lo = minus(m->pairs, m->npairs, want, nw, &nl);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_created(s, &p, &np));
    same_rows("created", cr, nc, p, np);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_lost(s, &p, &np));
    same_rows("lost", lo, nl, p, np);
    free(cr);
    free(lo);
    free(m->pairs);
    m->pairs = want;
    m->npairs = nw;
    TEST_ASSERT_EQUAL_UINT64(m->n, locd_scene_count(s));
    {
        locd_scene_stats st;
        locd_scene_stats_init(&st);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s, &st));
        g_updates++;
        g_incremental += st.rebuilt == 0;
    }
}

/* Updates the scene and checks pairs, created and lost against the model. */
static void check_update(locd_scene *s, model *m)
{
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS));
    check_lists(s, m);
}

/* ---- queries against the model ---- */
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

/* The reference slab test, written as docs/scene.md states it. */
static int ray_ref(const double *b, const double *o, const double *d, double max_t, double *t)
{
    double t0 = 0.0, t1 = max_t;
    int a;
    for (a = 0; a < 3; a++) {
        if (d[a] == 0.0) {
            if (o[a] < b[a] || o[a] > b[a + 3])
                return 0;
            continue;
        }
        {
            double u = (b[a] - o[a]) / d[a], v = (b[a + 3] - o[a]) / d[a];
            double lo = u < v ? u : v, hi = u < v ? v : u;
            t0 = lo > t0 ? lo : t0;
            t1 = hi < t1 ? hi : t1;
        }
    }
    *t = t0;
    return t0 <= t1;
}

/* kind 0 box, 1 point, 2 ray; q: 6 values (box), 3 (point) or o, d, max_t. */
static void check_query(const locd_scene *s, const model *m, int kind, const double *q, uint64_t mask)
{
    hit *want = malloc((m->n + 1) * sizeof *want);
    locd_id *ids = malloc((m->n + 1) * sizeof *ids);
    double *ts = malloc((m->n + 1) * sizeof *ts);
    size_t k, w = 0, count = 99;
    for (k = 0; k < m->n; k++) {
        const m_obj *o = &m->o[k];
        double t = 0.0, pb[6];
        int h;
        if (!(o->cat & mask))
            continue;
        if (kind == 0)
            h = overlap(o->box, q);
        else if (kind == 1) {
            memcpy(pb, q, 3 * sizeof *q);
            memcpy(pb + 3, q, 3 * sizeof *q);
            h = overlap(o->box, pb);
        } else
            h = ray_ref(o->box, q, q + 3, q[6], &t);
        if (h)
            want[w].t = t, want[w].id = o->id, w++;
    }
    qsort(want, w, sizeof *want, cmp_hit);
    if (kind == 0)
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_query_box_f64(s, q, mask, ids, m->n + 1, &count));
    else if (kind == 1)
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_query_point_f64(s, q, mask, ids, m->n + 1, &count));
    else
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_raycast_f64(s, q, q + 3, q[6], mask, ids, ts, m->n + 1, &count));
    TEST_ASSERT_EQUAL_UINT64(w, count);
    for (k = 0; k < w; k++) {
        if (ids[k] != want[k].id)
            LT_FAIL("query kind %d hit %zu: id %llx, expected %llx", kind, k, (unsigned long long)ids[k],
                    (unsigned long long)want[k].id);
        if (kind == 2 && memcmp(&ts[k], &want[k].t, sizeof(double)) != 0)
            LT_FAIL("ray hit %zu: t %.17g, expected %.17g", k, ts[k], want[k].t);
    }
    if (w > 0) { /* one short: nothing written, the count reported */
        ids[0] = 12345;
        if (kind == 0)
            TEST_ASSERT_EQUAL_INT(LOCD_ERR_BUFFER_TOO_SMALL, locd_scene_query_box_f64(s, q, mask, ids, w - 1, &count));
        else if (kind == 1)
            TEST_ASSERT_EQUAL_INT(LOCD_ERR_BUFFER_TOO_SMALL,
                                  locd_scene_query_point_f64(s, q, mask, ids, w - 1, &count));
        else
            TEST_ASSERT_EQUAL_INT(LOCD_ERR_BUFFER_TOO_SMALL,
                                  locd_scene_raycast_f64(s, q, q + 3, q[6], mask, ids, ts, w - 1, &count));
        TEST_ASSERT_EQUAL_UINT64(w, count);
        if (w > 1)
            TEST_ASSERT_EQUAL_UINT64(12345, ids[0]);
    }
    free(want);
    free(ids);
    free(ts);
}

/* x rounded to float. Through a volatile: GCC 12.2 at -O3 vectorizes
 * `f[i] = (float)d[i], d[i] = f[i]` into a loop that leaves d[i] unrounded. */
static float to_float(double x)
{
    volatile float t = (float)x;
    return t;
}

/* ---- random worlds ---- */
typedef struct world {
    ts_rng r;
    double extent; /* coordinates in [0, extent) */
    double size;   /* typical box edge */
    int shape;     /* 0 random, 1 lattice (touching faces), 2 far from the origin */
} world;

/* A world of random boxes: coordinates in [0, extent), edges about size. */
static world world_make(uint64_t seed, double extent, double size, int shape)
{
    world w;
    memset(&w, 0, sizeof w);
    ts_seed(&w.r, seed);
    w.extent = extent, w.size = size, w.shape = shape;
    return w;
}

static void random_box(world *w, double *b)
{
    int a;
    double base = w->shape == 2 ? 1e7 : 0.0;
    double e = w->size * (0.2 + ts_uniform(&w->r));
    if ((ts_next(&w->r) & 31) == 0)
        e *= 20.0; /* a huge one now and then */
    if ((ts_next(&w->r) & 31) == 1)
        e = 0.0; /* a point */
    for (a = 0; a < 3; a++) {
        double lo = base + ts_uniform(&w->r) * w->extent;
        if (w->shape == 1) {
            lo = base + floor(lo / w->size) * w->size;
            b[a] = lo;
            b[a + 3] = lo + w->size;
        } else {
            b[a] = lo;
            b[a + 3] = lo + e * (0.5 + ts_uniform(&w->r));
        }
    }
    if (w->shape == 2)
        for (a = 0; a < 6; a++)
            b[a] = to_float(b[a]); /* representable in float too */
}

static uint64_t random_bits(world *w)
{
    /* few bits, so that filters bite often */
    static const uint64_t v[] = {1, 2, 3, 4, 7, ~(uint64_t)0};
    return v[ts_next(&w->r) % 6];
}

typedef struct run_opts {
    uint32_t threads;
    int steps;
    int start; /* objects added first */
    int shape;
    int queries; /* queries per step */
    uint64_t seed;
} run_opts;

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

/* The tests of the kept entry list (kept_list.c) make their scenes with
 * this: their whole-scene moves of small steps would otherwise take the
 * near-pair list (near_list.c), which has tests of its own. */
static const locd_scene_config kept_cfg = {sizeof(locd_scene_config), LOCD_SCENE_NO_NEAR_LIST, 0};

static void random_query(world *w, const locd_scene *s, const model *m)
{
    double q[7];
    int kind = (int)(ts_next(&w->r) % 3);
    uint64_t mask = random_bits(w);
    random_box(w, q);
    if (kind == 0 && (ts_next(&w->r) & 3) == 0) { /* a large region */
        int a;
        for (a = 0; a < 3; a++)
            q[a + 3] = q[a] + w->extent * 0.5;
    }
    if (kind == 2) {
        int a;
        if ((ts_next(&w->r) & 7) == 0 && m->n) { /* start inside an object */
            const m_obj *o = &m->o[ts_next(&w->r) % m->n];
            for (a = 0; a < 3; a++)
                q[a] = o->box[a];
        }
        for (a = 0; a < 3; a++) {
            q[3 + a] = (ts_uniform(&w->r) - 0.5) * w->extent;
            if ((ts_next(&w->r) & 3) == 0)
                q[3 + a] = 0.0; /* parallel to a face */
        }
        q[6] = (ts_next(&w->r) & 3) == 0 ? HUGE_VAL : ts_uniform(&w->r) * 1.5;
    }
    check_query(s, m, kind, q, mask);
}

/* Runs one random sequence; returns a hash of every update's pair lists
 * (for the thread-count comparison). */
static uint64_t run_sequence(const run_opts *ro)
{
    world w;
    model m;
    locd_engine *e = new_engine(ro->threads, NULL);
    locd_scene *s = NULL;
    uint64_t hash = 1469598103934665603ull;
    int step, k;
    size_t big = ro->start > 256 ? (size_t)ro->start : 256;
    locd_id *ids = malloc(big * sizeof *ids);
    double *boxes = malloc(6 * big * sizeof *boxes);
    uint64_t *v[3];
    float *f = malloc(6 * big * sizeof *f);
    v[0] = malloc(3 * big * sizeof(uint64_t)), v[1] = v[0] + big, v[2] = v[1] + big;
    memset(&m, 0, sizeof m);
    w = world_make(ro->seed, 100.0, 4.0, ro->shape);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    for (step = 0; step < ro->steps; step++) {
        int op = step == 0 ? 0 : (int)(ts_next(&w.r) % 10);
        size_t n = step == 0 ? (size_t)ro->start : 1 + ts_next(&w.r) % 8;
        size_t i;
        if (op <= 1 || m.n < 10) { /* add */
            locd_scene_add_options o;
            int stat = (ts_next(&w.r) % 3) == 0;
            locd_scene_add_options_init(&o);
            o.flags = stat ? LOCD_OBJECT_STATIC : 0;
            for (i = 0; i < n; i++) {
                random_box(&w, boxes + 6 * i);
                v[0][i] = random_bits(&w), v[1][i] = random_bits(&w), v[2][i] = ts_next(&w.r) % 3;
            }
            o.categories = v[0], o.masks = v[1], o.groups = v[2];
            o.user = ts_next(&w.r);
            if (n > 4 && (ts_next(&w.r) & 1)) {
                for (i = 0; i < 6 * n; i++)
                    f[i] = to_float(boxes[i]), boxes[i] = f[i];
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s, f, n, &o, ids));
            } else {
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, boxes, n, &o, ids));
            }
            for (i = 0; i < n; i++)
                m_add(&m, ids[i], boxes + 6 * i, v[0][i], v[1][i], v[2][i], o.user, stat);
        } else if (op <= 5) { /* move: some by a small step, some anywhere */
            size_t cnt = 0;
            for (i = 0; i < n && i < m.n; i++) {
                const m_obj *o = &m.o[ts_next(&w.r) % m.n];
                size_t j;
                int a, dup = 0;
                for (j = 0; j < cnt; j++)
                    dup |= ids[j] == o->id;
                if (dup)
                    continue;
                ids[cnt] = o->id;
                if (ts_next(&w.r) & 1) {
                    double d = (ts_uniform(&w.r) - 0.5) * w.size;
                    for (a = 0; a < 6; a++)
                        boxes[6 * cnt + (size_t)a] = o->box[a] + (w.shape == 1 ? 0.0 : d);
                } else {
                    random_box(&w, boxes + 6 * cnt);
                }
                cnt++;
            }
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, ids, boxes, cnt));
            for (i = 0; i < cnt; i++)
                memcpy(m_find(&m, ids[i])->box, boxes + 6 * i, 6 * sizeof(double));
        } else if (op == 6) { /* remove */
            size_t cnt = 0;
            for (i = 0; i < n && m.n > 0; i++) {
                locd_id id = m.o[ts_next(&w.r) % m.n].id;
                ids[cnt++] = id;
                m_remove(&m, id);
            }
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, ids, cnt));
        } else if (op == 7) { /* filter */
            size_t cnt = 0;
            int which = (int)(ts_next(&w.r) % 4);
            for (i = 0; i < n && i < m.n; i++) {
                const m_obj *o = &m.o[ts_next(&w.r) % m.n];
                size_t j;
                int dup = 0;
                for (j = 0; j < cnt; j++)
                    dup |= ids[j] == o->id;
                if (dup)
                    continue;
                ids[cnt] = o->id;
                v[0][cnt] = random_bits(&w), v[1][cnt] = random_bits(&w), v[2][cnt] = ts_next(&w.r) % 3;
                cnt++;
            }
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s, ids, cnt, which != 1 ? v[0] : NULL,
                                                                 which != 2 ? v[1] : NULL, which != 3 ? v[2] : NULL));
            for (i = 0; i < cnt; i++) {
                m_obj *o = m_find(&m, ids[i]);
                if (which != 1)
                    o->cat = v[0][i];
                if (which != 2)
                    o->mask = v[1][i];
                if (which != 3)
                    o->group = v[2][i];
            }
        } else if (op == 8) { /* users */
            size_t cnt = 0;
            uint64_t *got = v[1];
            for (i = 0; i < n && i < m.n; i++) {
                const m_obj *o = &m.o[ts_next(&w.r) % m.n];
                size_t j;
                int dup = 0;
                for (j = 0; j < cnt; j++)
                    dup |= ids[j] == o->id;
                if (dup)
                    continue;
                ids[cnt] = o->id;
                v[0][cnt] = ts_next(&w.r);
                cnt++;
            }
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_user(s, ids, cnt, v[0]));
            for (i = 0; i < cnt; i++)
                m_find(&m, ids[i])->user = v[0][i];
            for (i = 0; i < m.n && i < 256; i++)
                ids[i] = m.o[i].id;
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_get_user(s, ids, i, got));
            while (i-- > 0)
                TEST_ASSERT_EQUAL_UINT64(m.o[i].user, got[i]);
        }
        /* op 9: no change */
        if ((ts_next(&w.r) % 3) != 0 || step == ro->steps - 1) {
            const locd_id *p;
            size_t np;
            check_update(s, &m);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s, &p, &np));
            for (i = 0; i < 2 * np; i++)
                hash = (hash ^ p[i]) * 1099511628211ull;
        }
        for (k = 0; k < ro->queries; k++)
            random_query(&w, s, &m);
    }
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o);
    free(m.pairs);
    free(ids), free(boxes), free(f), free(v[0]);
    return hash;
}

static void random_sequences(void)
{
    int shape;
    for (shape = 0; shape < 3; shape++) {
        run_opts ro = {1, 1500, 60, 0, 2, 0};
        ro.steps = steps(ro.steps);
        ro.shape = shape;
        ro.seed = 100 + (uint64_t)shape;
        g_updates = g_incremental = 0;
        run_sequence(&ro);
        LT_PRINT("shape %d: %u of %u updates incremental\n", shape, g_incremental, g_updates);
        /* the incremental path is what is under test */
        TEST_ASSERT_TRUE(g_incremental * 2 > g_updates);
    }
}

/* A dense scene (about 10^5 pairs: the from-scratch rows and events are
 * split over the threads) where every object moves, then a few, then some
 * are added and removed: a from-scratch update drops the entry lists, the
 * next small one builds them again before its search, queries in between
 * test every object. Float-exact boxes and default filters (the float find,
 * no filter pass) or double boxes, static objects and random filters. */
static void whole_scene_moves_then_a_few(void)
{
    int variant, frame;
    uint32_t threads;
    for (variant = 0; variant < 2; variant++)
        for (threads = 1; threads <= 2; threads++) {
            const size_t n0 = 3000;
            world w;
            model m;
            locd_engine *e = new_engine(threads, NULL);
            locd_scene *s = NULL;
            locd_scene_add_options o;
            locd_scene_stats st;
            locd_id *ids = malloc(n0 * sizeof *ids);
            double *boxes = malloc(6 * n0 * sizeof *boxes);
            float *f = malloc(6 * n0 * sizeof *f);
            size_t i, k;
            memset(&m, 0, sizeof m);
            w = world_make(77 + (uint64_t)variant, 20.0, 4.0, 0);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
            locd_scene_add_options_init(&o);
            for (i = 0; i < n0; i++) {
                random_box(&w, boxes + 6 * i);
                if (variant == 0)
                    for (k = 0; k < 6; k++)
                        f[6 * i + k] = to_float(boxes[6 * i + k]), boxes[6 * i + k] = f[6 * i + k];
            }
            if (variant == 0) {
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s, f, n0, &o, ids));
                for (i = 0; i < n0; i++)
                    m_add(&m, ids[i], boxes + 6 * i, 1, ~(uint64_t)0, 0, 0, 0);
            } else {
                o.flags = LOCD_OBJECT_STATIC;
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, boxes, 300, &o, ids));
                o.flags = 0;
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, boxes + 6 * 300, n0 - 300, &o, ids + 300));
                for (i = 0; i < n0; i++)
                    m_add(&m, ids[i], boxes + 6 * i, 1, ~(uint64_t)0, 0, 0, i < 300);
                for (i = 0; i < 400; i++) { /* filters on a few */
                    uint64_t c = random_bits(&w), mk = random_bits(&w), g = ts_next(&w.r) % 3;
                    m_obj *mo = &m.o[(size_t)(ts_next(&w.r) % n0)];
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s, &mo->id, 1, &c, &mk, &g));
                    mo->cat = c, mo->mask = mk, mo->group = g;
                }
            }
            for (frame = 0; frame < 9; frame++) {
                int kind = frame % 3; /* 0 all move, 1: 1% move, 2: add, remove, move a few */
                size_t cnt = 0;
                if (kind == 0 || kind == 1) {
                    size_t every = kind == 0 ? 1 : 97;
                    for (i = 0; i < m.n; i += every) {
                        double d = (ts_uniform(&w.r) - 0.5) * 0.4;
                        ids[cnt] = m.o[i].id;
                        for (k = 0; k < 6; k++) {
                            boxes[6 * cnt + k] = m.o[i].box[k] + d;
                            if (variant == 0)
                                boxes[6 * cnt + k] = to_float(boxes[6 * cnt + k]);
                        }
                        memcpy(m.o[i].box, boxes + 6 * cnt, 6 * sizeof(double));
                        cnt++;
                    }
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, ids, boxes, cnt));
                } else {
                    for (i = 0; i < 5; i++) {
                        ids[i] = m.o[(size_t)(ts_next(&w.r) % m.n)].id;
                        m_remove(&m, ids[i]);
                    }
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, ids, 5));
                    for (i = 0; i < 5; i++)
                        random_box(&w, boxes + 6 * i);
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, boxes, 5, NULL, ids));
                    for (i = 0; i < 5; i++)
                        m_add(&m, ids[i], boxes + 6 * i, 1, ~(uint64_t)0, 0, 0, 0);
                }
                for (k = 0; k < 5; k++) /* changes pending */
                    random_query(&w, s, &m);
                check_update(s, &m);
                locd_scene_stats_init(&st);
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s, &st));
                TEST_ASSERT_EQUAL_UINT32(kind == 0 ? 1u : 0u, st.rebuilt);
                if (frame == 0)
                    TEST_ASSERT_TRUE(m.npairs > 65536); /* the threads' split is used */
                for (k = 0; k < 10; k++)
                    random_query(&w, s, &m);
            }
            locd_scene_destroy(s);
            locd_engine_destroy(e);
            free(m.o);
            free(m.pairs);
            free(ids), free(boxes), free(f);
        }
}

/* ---- fat boxes and partner lists (docs/scene.md) ---- */

/* A box of the partner-list test: cubes of edge 0.5-1.5 in [0, 22]^3,
 * with a point now and then and a large box rarely. */
static void pl_box(world *w, double *b)
{
    double e = 0.5 + ts_uniform(&w->r);
    int a, kind = (int)(ts_next(&w->r) % 100);
    if (kind == 0)
        e = 0.0;
    else if (kind == 1)
        e = 5.0;
    for (a = 0; a < 3; a++) {
        b[a] = ts_uniform(&w->r) * 22.0;
        b[a + 3] = b[a] + e;
    }
}

/* Moves the model's object i by at most step on each axis, in the scene too. */
static void pl_move(locd_scene *s, world *w, m_obj *o, double step)
{
    double b[6];
    int a;
    for (a = 0; a < 3; a++) {
        const double d = (ts_uniform(&w->r) - 0.5) * 2.0 * step;
        b[a] = o->box[a] + d, b[a + 3] = o->box[a + 3] + d;
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, &o->id, b, 1));
    memcpy(o->box, b, sizeof b);
}

/* The partner lists through their life: objects moving a little each frame
 * take their pairs from their lists (stats.coasted); a frame where most
 * moved objects leave their fat boxes drops the lists (every moved object
 * searches, the update stays incremental); after LC_CALM_UPDATES calm
 * updates the lists are built again. Statics move too; adds, removes and
 * filter changes come in between. Every frame against the model, with
 * over 65,536 pairs (the two threads' patch of the set). */
static void partner_lists_come_and_go(void)
{
    const size_t n0 = 16000;
    world w = world_make(5151, 22.0, 1.0, 0);
    model m;
    locd_engine *e = new_engine(2, NULL);
    locd_scene *s = NULL;
    locd_scene_add_options o;
    locd_scene_stats st;
    double b[6];
    size_t i, k;
    int frame;
    memset(&m, 0, sizeof m);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    locd_scene_add_options_init(&o);
    for (i = 0; i < n0; i++) {
        locd_id id;
        const int stat = i % 10 == 0;
        uint64_t cat = 1, mask = ~(uint64_t)0, group = 0;
        if (i % 7 == 0)
            cat = random_bits(&w), mask = random_bits(&w), group = ts_next(&w.r) % 3;
        pl_box(&w, b);
        o.flags = stat ? LOCD_OBJECT_STATIC : 0;
        o.category = cat, o.mask = mask, o.group = group;
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, 1, &o, &id));
        m_add(&m, id, b, cat, mask, group, 0, stat);
    }
    check_update(s, &m);
    TEST_ASSERT_TRUE(m.npairs > 65536);
    for (frame = 1; frame <= 13; frame++) {
        const int teleport = frame == 6;
        size_t moved = 0;
        if (teleport) {
            /* more leave their fat boxes than stay, at least LC_ADJ_MIN_LEFT
               (1,024), under 8% of the objects: lists dropped, incremental */
            for (k = 0; k < 1100; k++) {
                m_obj *mo = &m.o[(k * 13 + 1) % m.n];
                pl_box(&w, b);
                b[0] += 0.01, b[3] += 0.01; /* never where it was */
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, &mo->id, b, 1));
                memcpy(mo->box, b, sizeof b);
            }
            for (k = 0; k < 100; k++)
                pl_move(s, &w, &m.o[(k * 13 + 7) % m.n], 0.002);
        } else {
            for (i = (size_t)frame % 50; i < m.n; i += 50, moved++) /* 2%, a little */
                pl_move(s, &w, &m.o[i], 0.002);
        }
        if (frame == 5) { /* removes, adds, filters, on top */
            locd_id ids[20];
            uint64_t c[20], mk[20], g[20];
            for (k = 0; k < 20; k++)
                ids[k] = m.o[(k * 101 + 3) % m.n].id;
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, ids, 20));
            for (k = 0; k < 20; k++)
                m_remove(&m, ids[k]);
            o.flags = 0, o.category = 1, o.mask = ~(uint64_t)0, o.group = 0;
            for (k = 0; k < 20; k++) {
                locd_id id;
                pl_box(&w, b);
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, 1, &o, &id));
                m_add(&m, id, b, 1, ~(uint64_t)0, 0, 0, 0);
            }
            for (k = 0; k < 20; k++) {
                m_obj *mo = &m.o[(k * 37 + 11) % m.n];
                ids[k] = mo->id, c[k] = random_bits(&w), mk[k] = random_bits(&w), g[k] = ts_next(&w.r) % 3;
                mo->cat = c[k], mo->mask = mk[k], mo->group = g[k];
            }
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s, ids, 20, c, mk, g));
        }
        check_update(s, &m);
        for (k = 0; k < 3; k++)
            random_query(&w, s, &m);
        locd_scene_stats_init(&st);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s, &st));
        TEST_ASSERT_EQUAL_UINT32(0, st.rebuilt);
        if (frame <= 5 || frame >= 11) /* the lists: built by frame 1, again at frame 10's commit */
            TEST_ASSERT_TRUE(st.coasted * 10 >= moved * 9);
        else /* dropped at frame 6, none till then */
            TEST_ASSERT_EQUAL_UINT32(0, st.coasted);
    }
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o);
    free(m.pairs);
}

static void bigger_scene_two_threads(void)
{
    run_opts ro = {2, 200, 3000, 0, 1, 7};
    ro.steps = steps(ro.steps);
    run_sequence(&ro);
}

static void thread_counts_give_identical_lists(void)
{
    run_opts ro = {1, 300, 2000, 0, 0, 99};
    uint64_t h1, h2;
    ro.steps = steps(ro.steps);
    h1 = run_sequence(&ro);
    ro.threads = 2;
    h2 = run_sequence(&ro);
    TEST_ASSERT_EQUAL_UINT64(h1, h2);
}

/* A fingerprint of the scene: its pairs after an update and a big query. */
static uint64_t fingerprint(locd_scene *s)
{
    const locd_id *p;
    size_t np, i, nq = 0;
    locd_id ids[64];
    double q[6] = {-1e9, -1e9, -1e9, 1e9, 1e9, 1e9};
    uint64_t h = 1469598103934665603ull;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_query_box_f64(s, q, ~(uint64_t)0, ids, 64, &nq));
    for (i = 0; i < nq; i++)
        h = (h ^ ids[i]) * 1099511628211ull;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s, &p, &np));
    for (i = 0; i < 2 * np; i++)
        h = (h ^ p[i]) * 1099511628211ull;
    return h ^ locd_scene_count(s);
}

static void bad_batches_change_nothing(void)
{
    locd_engine *e = new_engine(1, NULL);
    locd_scene *s = NULL;
    double b[6 * 8];
    float f[6 * 8];
    locd_id ids[8], bad[4], removed;
    uint64_t v[4] = {1, 2, 3, 4}, h;
    int i;
    for (i = 0; i < 8; i++) {
        int a;
        for (a = 0; a < 3; a++)
            b[6 * i + a] = i * 0.5 + a, b[6 * i + 3 + a] = i * 0.5 + a + 1.0;
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, 8, NULL, ids));
    removed = ids[7];
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, &removed, 1));
    h = fingerprint(s);
    TEST_ASSERT_TRUE(h == fingerprint(s));
    /* stale: removed, never issued, id 0 */
    bad[0] = ids[0], bad[1] = ids[1], bad[2] = removed;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_scene_move_f64(s, bad, b, 3));
    TEST_ASSERT_EQUAL_INT64(2, locd_last_error_index());
    bad[2] = ids[6] + ((uint64_t)1000 << 32);
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_scene_remove(s, bad, 3));
    TEST_ASSERT_EQUAL_INT64(2, locd_last_error_index());
    bad[1] = LOCD_ID_NONE;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_scene_set_filter(s, bad, 2, v, NULL, NULL));
    TEST_ASSERT_EQUAL_INT64(1, locd_last_error_index());
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_scene_set_user(s, bad, 2, v));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_scene_get_user(s, bad, 2, v));
    /* duplicates */
    bad[0] = ids[0], bad[1] = ids[1], bad[2] = ids[0];
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_DUPLICATE_ID, locd_scene_move_f64(s, bad, b, 3));
    TEST_ASSERT_EQUAL_INT64(2, locd_last_error_index());
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_DUPLICATE_ID, locd_scene_remove(s, bad, 3));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_DUPLICATE_ID, locd_scene_set_filter(s, bad, 3, v, v, v));
    /* NaN and inverted boxes, f64 and f32, add and move */
    for (i = 0; i < 48; i++)
        f[i] = (float)b[i];
    b[6 * 2 + 4] = NAN;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_NONFINITE, locd_scene_add_f64(s, b, 4, NULL, bad));
    TEST_ASSERT_EQUAL_INT64(2, locd_last_error_index());
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_NONFINITE, locd_scene_move_f64(s, ids, b, 4));
    TEST_ASSERT_EQUAL_INT64(2, locd_last_error_index());
    f[6 * 3 + 0] = 10.0f;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVERTED_BOX, locd_scene_add_f32(s, f, 4, NULL, bad));
    TEST_ASSERT_EQUAL_INT64(3, locd_last_error_index());
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVERTED_BOX, locd_scene_move_f32(s, ids, f, 4));
    TEST_ASSERT_EQUAL_INT64(3, locd_last_error_index());
    f[6 * 3 + 0] = INFINITY;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_NONFINITE, locd_scene_move_f32(s, ids, f, 4));
    TEST_ASSERT_TRUE(h == fingerprint(s));
    TEST_ASSERT_EQUAL_UINT64(7, locd_scene_count(s));
    locd_scene_destroy(s);
    locd_engine_destroy(e);
}

static void levels_2_and_3_are_unsupported(void)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_scene *s = (locd_scene *)&cfg;
    locd_engine_config_init(&cfg);
    cfg.level = LOCD_LEVEL_WORKERS;
    cfg.threads = 1;
    if (locd_engine_create(&cfg, &e) != LOCD_OK)
        TEST_IGNORE_MESSAGE("no level-2 engine here");
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_UNSUPPORTED, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_NULL(s);
    TEST_ASSERT_NOT_NULL(strstr(locd_last_error(), "level 1"));
    locd_engine_destroy(e);
}

/* A scene fed floats keeps no doubles; the first double box that is not a
 * float exactly makes them. That allocation failing rejects the batch and
 * changes nothing; once it works, the pairs and the queries see the double
 * boxes, not their floats (a box 1e-9 apart from another only as doubles). */
static void doubles_come_in_late(void)
{
    locd_engine *e = new_engine(2, fa_allocator());
    locd_scene *s = NULL;
    enum { N0 = 3000 };
    double *b = malloc(6 * N0 * sizeof *b);
    float *f = malloc(6 * N0 * sizeof *f);
    locd_id *ids = malloc(N0 * sizeof *ids);
    double q[7];
    uint64_t k;
    int i, a, failed = 0;
    world w;
    model m;
    w = world_make(11, 60.0, 3.0, 0);
    memset(&m, 0, sizeof m);
    for (i = 0; i < 6 * N0; i++) {
        if (i % 6 == 0)
            random_box(&w, b + i);
        f[i] = to_float(b[i]), b[i] = f[i];
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s, f, N0, NULL, ids));
    for (i = 0; i < N0; i++)
        m_add(&m, ids[i], b + 6 * i, 1, ~(uint64_t)0, 0, 0, 0);
    check_update(s, &m);
    /* Object 1 moves to touch object 0's high x face from beyond it by
       1e-9: as floats the two would touch; as doubles they do not. Object 2
       takes object 1's old box nudged by 1e-9, overlapping as doubles. */
    for (a = 0; a < 6; a++) {
        b[a] = m.o[0].box[a];
        b[6 + a] = m.o[0].box[a] + (a == 0 ? m.o[0].box[3] - m.o[0].box[0] + 1e-9 : 0.0);
        b[12 + a] = m.o[1].box[a] + 1e-9;
    }
    b[9] = b[6] + 1.0;
    for (k = 1; k < 1000; k++) {
        locd_status st;
        fa_counts c;
        fa_arm(k, 0);
        st = locd_scene_move_f64(s, ids, b, 3);
        fa_counts_get(&c);
        fa_arm(0, 0);
        if (st == LOCD_OK)
            break;
        TEST_ASSERT_EQUAL_INT(LOCD_ERR_NO_MEMORY, st);
        TEST_ASSERT_TRUE(c.failures > 0);
        failed++;
        check_update(s, &m); /* nothing moved */
    }
    TEST_ASSERT_TRUE(failed > 0);
    for (i = 0; i < 3; i++)
        memcpy(m_find(&m, ids[i])->box, b + 6 * i, 6 * sizeof(double));
    check_update(s, &m);
    /* a query between the two as doubles: a point on object 1's low face */
    for (a = 0; a < 3; a++)
        q[a] = b[6 + a];
    check_query(s, &m, 1, q, ~(uint64_t)0);
    for (a = 0; a < 6; a++)
        q[a] = b[6 + a];
    check_query(s, &m, 0, q, ~(uint64_t)0);
    /* more float moves and a big double move on the pool keep it exact */
    for (i = 0; i < N0; i++)
        for (a = 0; a < 6; a++)
            b[6 * i + a] = m_find(&m, ids[i])->box[a] + 1e-7 * (double)(i % 5);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, ids, b, N0));
    for (i = 0; i < N0; i++)
        memcpy(m_find(&m, ids[i])->box, b + 6 * i, 6 * sizeof(double));
    check_update(s, &m);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o);
    free(m.pairs);
    free(b);
    free(f);
    free(ids);
}

/* Every allocation of a change or an update fails in turn: the call gives
 * LOCD_ERR_NO_MEMORY, and the scene then behaves as if the failed call had
 * not been made (checked against the model by the next, working update). */
static void allocation_failures_change_nothing(void)
{
    locd_engine *e = new_engine(1, fa_allocator());
    locd_scene *s = NULL;
    enum { N0 = 2000 };
    double *b = malloc(6 * N0 * sizeof *b);
    locd_id *ids = malloc(N0 * sizeof *ids), more[8];
    uint64_t k;
    int i, round, failed_calls = 0;
    world w;
    model m;
    w = world_make(5, 60.0, 3.0, 0);
    memset(&m, 0, sizeof m);
    for (i = 0; i < N0; i++)
        random_box(&w, b + 6 * i);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, N0, NULL, ids));
    for (i = 0; i < N0; i++)
        m_add(&m, ids[i], b + 6 * i, 1, ~(uint64_t)0, 0, 0, 0);
    check_update(s, &m);
    for (round = 0; round < 4; round++) {
        for (k = 1; k < 400; k++) {
            locd_status st;
            fa_counts c;
            for (i = 0; i < 8; i++) {
                random_box(&w, b + 6 * i);
                if (round == 3) { /* far outside the root cube: the update rebuilds */
                    int a;
                    for (a = 0; a < 6; a++)
                        b[6 * i + a] += 1000.0;
                }
            }
            fa_arm(k, 0);
            if (round == 0 || round == 3)
                st = locd_scene_add_f64(s, b, 8, NULL, more);
            else
                st = locd_scene_move_f64(s, ids + 8 * (size_t)((50 * round + (int)k) % (N0 / 8)), b, 8);
            if (st == LOCD_OK) { /* the change went in: the model follows */
                for (i = 0; i < 8; i++) {
                    if (round == 0 || round == 3)
                        m_add(&m, more[i], b + 6 * i, 1, ~(uint64_t)0, 0, 0, 0);
                    else
                        memcpy(m_find(&m, ids[8 * (size_t)((50 * round + (int)k) % (N0 / 8)) + (size_t)i])->box, b + 6 * i,
                               6 * sizeof(double));
                }
                st = locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS);
            }
            fa_counts_get(&c);
            fa_arm(0, 0);
            if (c.failures == 0 || st == LOCD_OK) {
                /* a failure may be absorbed (the lists' directory is only a
                   shortcut): the answer must still be exact */
                TEST_ASSERT_EQUAL_INT(LOCD_OK, st);
                check_lists(s, &m);
                if (c.failures == 0)
                    break;
                continue;
            }
            TEST_ASSERT_EQUAL_INT(LOCD_ERR_NO_MEMORY, st);
            failed_calls++;
            /* pending changes (if the update failed) go in now; the lists must
               equal the model's, created and lost against the last good update */
            check_update(s, &m);
            if (round == 0 || round == 3) { /* keep the scene small: remove what was added */
                size_t cnt = 0;
                locd_id rm[8];
                for (i = 0; i < 8 && locd_scene_count(s) > N0; i++) {
                    locd_id id = m.o[m.n - 1].id;
                    rm[cnt++] = id;
                    m_remove(&m, id);
                }
                if (cnt)
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, rm, cnt));
                check_update(s, &m);
            }
        }
    }
    LT_PRINT("allocation failures: %d failed calls, each left the scene as before\n", failed_calls);
    TEST_ASSERT_TRUE(failed_calls > 20);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o);
    free(m.pairs);
    free(b);
    free(ids);
    {
        fa_counts c;
        fa_counts_get(&c);
        TEST_ASSERT_EQUAL_UINT64(0, c.bad_frees);
        TEST_ASSERT_EQUAL_UINT64(0, c.live_blocks);
    }
}

/* The pairs of a fresh scene of the model's objects (its first update is a
 * rebuild), in the model's ids, sorted. */
static locd_id *fresh_pairs(locd_engine *e, const model *m, size_t *count)
{
    locd_scene *f = NULL;
    locd_scene_add_options o;
    double *b = malloc((m->n + 1) * 6 * sizeof *b);
    uint64_t *v = malloc((m->n + 1) * 3 * sizeof *v);
    locd_id *ids = malloc((m->n + 1) * sizeof *ids), *map = malloc((m->n + 1) * sizeof *map), *rows;
    const locd_id *p;
    size_t k, np, nmap = 0;
    int stat;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &f));
    for (stat = 0; stat < 2; stat++) { /* one batch per kind; the fresh scene's serials are 1, 2, ... */
        size_t n = 0;
        for (k = 0; k < m->n; k++)
            if (m->o[k].stat == stat) {
                memcpy(b + 6 * n, m->o[k].box, 6 * sizeof *b);
                v[n] = m->o[k].cat, v[m->n + n] = m->o[k].mask, v[2 * m->n + n] = m->o[k].group;
                map[nmap + n] = m->o[k].id;
                n++;
            }
        locd_scene_add_options_init(&o);
        o.flags = stat ? LOCD_OBJECT_STATIC : 0;
        o.categories = v, o.masks = v + m->n, o.groups = v + 2 * m->n;
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(f, b, n, &o, ids));
        nmap += n;
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(f, LOCD_SCENE_UPDATE_PAIRS));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(f, &p, &np));
    rows = malloc((np + 1) * 2 * sizeof *rows);
    for (k = 0; k < np; k++) {
        locd_id a = map[(p[2 * k] >> 32) - 1], c = map[(p[2 * k + 1] >> 32) - 1];
        rows[2 * k] = a < c ? a : c;
        rows[2 * k + 1] = a < c ? c : a;
    }
    qsort(rows, np, 2 * sizeof *rows, cmp_row);
    *count = np;
    locd_scene_destroy(f);
    free(b), free(v), free(ids), free(map);
    return rows;
}

/* A scene with more than 65536 pairs (the carry pass and the search split
 * over threads), 1 and 2 threads side by side, each update against a fresh
 * scene of the same objects. */
static void large_scene_threads_and_fresh(void)
{
    locd_engine *e1 = new_engine(1, NULL), *e2 = new_engine(2, NULL);
    locd_scene *s1 = NULL, *s2 = NULL;
    const size_t n = 30000;
    double *b = malloc(n * 6 * sizeof *b);
    locd_id *ids1 = malloc(n * sizeof *ids1), *ids2 = malloc(n * sizeof *ids2), *mv = malloc(n * sizeof *mv);
    model m;
    world w;
    size_t k, i;
    int step;
    memset(&m, 0, sizeof m);
    w = world_make(4242, 100.0, 6.0, 0);
    for (k = 0; k < n; k++)
        random_box(&w, b + 6 * k);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e1, NULL, &s1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e2, NULL, &s2));
    {
        locd_scene_add_options o;
        locd_scene_add_options_init(&o);
        o.flags = LOCD_OBJECT_STATIC;
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s1, b, n / 3, &o, ids1));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s2, b, n / 3, &o, ids2));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s1, b + 6 * (n / 3), n - n / 3, NULL, ids1 + n / 3));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s2, b + 6 * (n / 3), n - n / 3, NULL, ids2 + n / 3));
    }
    TEST_ASSERT_EQUAL_MEMORY(ids1, ids2, n * sizeof *ids1);
    for (k = 0; k < n; k++)
        m_add(&m, ids1[k], b + 6 * k, 1, ~(uint64_t)0, 0, 0, k < n / 3);
    for (step = 0; step < steps(12); step++) {
        const locd_id *p1, *p2;
        size_t n1, n2, nf;
        locd_id *want;
        size_t cnt = (size_t)(step % 3 == 0 ? n / 100 : n / 20);
        for (i = 0; i < cnt; i++) { /* distinct: a stride walk */
            size_t j = (ts_next(&w.r) % 7 + i * 13) % m.n;
            int a;
            double d = (ts_uniform(&w.r) - 0.5) * 2.0;
            m_obj *o = &m.o[j];
            size_t q;
            int dup = 0;
            for (q = 0; q < i; q++)
                dup |= mv[q] == o->id;
            if (dup) {
                cnt = i;
                break;
            }
            for (a = 0; a < 6; a++)
                o->box[a] += d;
            mv[i] = o->id;
            memcpy(b + 6 * i, o->box, 6 * sizeof *b);
        }
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s1, mv, b, cnt));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s2, mv, b, cnt));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s1, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s2, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s1, &p1, &n1));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s2, &p2, &n2));
        TEST_ASSERT_TRUE(n1 > 65536);
        same_rows("1 thread against 2", p1, n1, p2, n2);
        want = fresh_pairs(e1, &m, &nf);
        same_rows("pairs against a fresh scene", want, nf, p1, n1);
        free(want);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_created(s1, &p1, &n1));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_created(s2, &p2, &n2));
        same_rows("1 thread against 2", p1, n1, p2, n2);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_lost(s1, &p1, &n1));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_lost(s2, &p2, &n2));
        same_rows("1 thread against 2", p1, n1, p2, n2);
    }
    locd_scene_destroy(s1);
    locd_scene_destroy(s2);
    locd_engine_destroy(e1);
    locd_engine_destroy(e2);
    free(b), free(ids1), free(ids2), free(mv), free(m.o), free(m.pairs);
}

/* Object k's box on a 200 x 200 x 4 lattice of unit cubes along x (so
 * x-neighbours touch), y and z 3 apart; odd ones shrunk by `gap` (1e-9:
 * apart as doubles, touching once rounded to floats). */
static void lattice_box(size_t k, double gap, double *b)
{
    double x = (double)(k % 200), y = 3.0 * (double)((k / 200) % 200), z = 3.0 * (double)(k / 40000);
    double g = (k & 1) ? gap : 0.0;
    b[0] = x + g, b[1] = y, b[2] = z, b[3] = x + 1.0 - g, b[4] = y + 1.0, b[5] = z + 1.0;
}

/* Moves ids[pos[0..cnt)] to the boxes lattice_box gives them, in scene s1
 * (one thread: the serial loop) and s2 (two threads: move.c), f64 or f32. */
static void move_both(locd_scene *s1, locd_scene *s2, model *m, const locd_id *ids, const size_t *pos, size_t cnt,
                      double gap, int f32)
{
    locd_id *mv = malloc(cnt * sizeof *mv);
    double *b = malloc(cnt * 6 * sizeof *b);
    float *f = malloc(cnt * 6 * sizeof *f);
    size_t i;
    int a;
    for (i = 0; i < cnt; i++) {
        mv[i] = ids[pos[i]];
        lattice_box(pos[i], gap, b + 6 * i);
        for (a = 0; a < 6; a++) {
            f[6 * i + a] = (float)b[6 * i + a];
            if (f32)
                b[6 * i + a] = f[6 * i + a];
        }
        memcpy(m->o[pos[i]].box, b + 6 * i, 6 * sizeof *b);
    }
    if (f32) {
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s1, mv, f, cnt));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s2, mv, f, cnt));
    } else {
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s1, mv, b, cnt));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s2, mv, b, cnt));
    }
    free(mv), free(b), free(f);
}

/* Updates both scenes and checks both against a fresh scene of the model. */
static void update_both(locd_engine *e, locd_scene *s1, locd_scene *s2, model *m)
{
    const locd_id *p1, *p2;
    size_t n1, n2, nf;
    locd_id *want;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s1, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s2, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s1, &p1, &n1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s2, &p2, &n2));
    same_rows("two threads' moves against one thread's", p1, n1, p2, n2);
    if (steps(10) == 10) { /* the sanitizer runs (LOCD_TEST_HEAVY=0) compare the two scenes only */
        want = fresh_pairs(e, m, &nf);
        same_rows("one thread's moves against a fresh scene", want, nf, p1, n1);
        same_rows("two threads' moves against a fresh scene", want, nf, p2, n2);
        free(want);
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_created(s1, &p1, &n1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_created(s2, &p2, &n2));
    same_rows("created: 1 thread against 2", p1, n1, p2, n2);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_lost(s1, &p1, &n1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_lost(s2, &p2, &n2));
    same_rows("lost: 1 thread against 2", p1, n1, p2, n2);
}

/* The pairs after an update (pending changes taken in), hashed with the
 * count of objects: fingerprint() for scenes too big for its query. */
static uint64_t pairs_hash(locd_scene *s)
{
    const locd_id *p;
    size_t np, i;
    uint64_t h = 1469598103934665603ull;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s, &p, &np));
    for (i = 0; i < 2 * np; i++)
        h = (h ^ p[i]) * 1099511628211ull;
    return h ^ locd_scene_count(s);
}

/* A move of float (f64 0) or double boxes. */
static locd_status move_any(locd_scene *s, const locd_id *mv, const void *b, int f64, size_t cnt)
{
    return f64 ? locd_scene_move_f64(s, mv, b, cnt) : locd_scene_move_f32(s, mv, b, cnt);
}

/* One bad batch given to both scenes: the same error at the same position,
 * and neither scene changed. */
static void bad_move_both(locd_scene *s1, locd_scene *s2, const locd_id *mv, const void *b, int f64, size_t cnt,
                          locd_status want, int64_t at)
{
    uint64_t h1 = pairs_hash(s1), h2 = pairs_hash(s2);
    TEST_ASSERT_EQUAL_INT(want, move_any(s1, mv, b, f64, cnt));
    TEST_ASSERT_EQUAL_INT64(at, locd_last_error_index());
    TEST_ASSERT_EQUAL_INT(want, move_any(s2, mv, b, f64, cnt));
    TEST_ASSERT_EQUAL_INT64(at, locd_last_error_index());
    TEST_ASSERT_TRUE(h1 == pairs_hash(s1));
    TEST_ASSERT_TRUE(h2 == pairs_hash(s2));
}

/* A move of 65,536 objects or more runs on the pool (lib/scene/move.c):
 * the same lists as the serial loop's, in shuffled and overlapping
 * batches, with boxes that are floats exactly and boxes that are not (the
 * count of those decides whether the from-scratch path may use floats); a
 * later small move finds every moved object clean (the dirty list was
 * written right); and a bad batch names the position the serial checks
 * name (stale before repeated before bad box) and changes nothing. */
static void large_moves_on_the_pool(void)
{
    const size_t n = 140000, half = 70000;
    locd_engine *e1 = new_engine(1, NULL), *e2 = new_engine(2, NULL);
    locd_scene *s1 = NULL, *s2 = NULL;
    locd_id *ids1 = malloc(n * sizeof *ids1), *ids2 = malloc(n * sizeof *ids2), *mv = malloc(n * sizeof *mv);
    size_t *pos = malloc(n * sizeof *pos), k;
    double *b = malloc(n * 6 * sizeof *b);
    model m;
    ts_rng r;
    memset(&m, 0, sizeof m);
    ts_seed(&r, 515);
    for (k = 0; k < n; k++)
        lattice_box(k, 0.0, b + 6 * k);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e1, NULL, &s1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e2, NULL, &s2));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s1, b, n, NULL, ids1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s2, b, n, NULL, ids2));
    TEST_ASSERT_EQUAL_MEMORY(ids1, ids2, n * sizeof *ids1);
    for (k = 0; k < n; k++)
        m_add(&m, ids1[k], b + 6 * k, 1, ~(uint64_t)0, 0, 0, 0);
    update_both(e1, s1, s2, &m);
    /* the second half, shuffled, shrunk (not floats: no pair); then a few,
       incrementally: a slot left out of the dirty list would stay flagged
       dirty and its next move would be missed */
    for (k = 0; k < half; k++)
        pos[k] = half + k;
    for (k = half - 1; k > 0; k--) {
        size_t j = (size_t)(ts_next(&r) % (k + 1)), t = pos[k];
        pos[k] = pos[j], pos[j] = t;
    }
    move_both(s1, s2, &m, ids1, pos, half, 1e-9, 0);
    update_both(e1, s1, s2, &m);
    for (k = 0; k < 500; k++)
        pos[k] = (size_t)(ts_next(&r) % (n / 500)) + k * (n / 500);
    move_both(s1, s2, &m, ids1, pos, 500, 0.0, 0);
    update_both(e1, s1, s2, &m);
    /* the first half shrunk, then an overlapping range back to the lattice */
    for (k = 0; k < half; k++)
        pos[k] = k;
    move_both(s1, s2, &m, ids1, pos, half, 1e-9, 0);
    for (k = 0; k < half; k++)
        pos[k] = half / 2 + k;
    move_both(s1, s2, &m, ids1, pos, half, 0.0, 0);
    update_both(e1, s1, s2, &m);
    /* everything as floats, then shrunk again as doubles */
    for (k = 0; k < n; k++)
        pos[k] = n - 1 - k;
    move_both(s1, s2, &m, ids1, pos, n, 0.0, 1);
    update_both(e1, s1, s2, &m);
    move_both(s1, s2, &m, ids1, pos, n, 1e-9, 0);
    update_both(e1, s1, s2, &m);
    /* a few, incrementally: every slot must have left the dirty list */
    for (k = 0; k < 500; k++)
        pos[k] = (size_t)(ts_next(&r) % (n / 500)) + k * (n / 500);
    move_both(s1, s2, &m, ids1, pos, 500, 0.0, 0);
    update_both(e1, s1, s2, &m);
    {
        locd_scene_stats st;
        locd_scene_stats_init(&st);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s2, &st));
        TEST_ASSERT_EQUAL_UINT32(0, st.rebuilt);
        TEST_ASSERT_EQUAL_UINT64(500, st.moved);
    }
    /* an incremental update long enough to split its dirty list over the
       pool (LC_ENCODE_SPLIT, update.c): 10,000 moved, every 14th, and 100
       added (new dense indices taken in each part's turn) */
    {
        locd_id added1[100], added2[100], more1[5], more2[5];
        locd_scene_stats st;
        for (k = 0; k < 100; k++)
            lattice_box(n + k, 0.0, b + 6 * k);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s1, b, 100, NULL, added1));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s2, b, 100, NULL, added2));
        TEST_ASSERT_EQUAL_MEMORY(added1, added2, sizeof added1);
        for (k = 0; k < 100; k++)
            m_add(&m, added1[k], b + 6 * k, 1, ~(uint64_t)0, 0, 0, 0);
        for (k = 0; k < 10000; k++)
            pos[k] = 14 * k + (k & 3);
        move_both(s1, s2, &m, ids1, pos, 10000, 0.25, 0); /* odd ones shrunk: their touching pairs lost */
        update_both(e1, s1, s2, &m);
        locd_scene_stats_init(&st);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s2, &st));
        TEST_ASSERT_EQUAL_UINT32(0, st.rebuilt);
        TEST_ASSERT_EQUAL_UINT64(10100, st.moved);
        for (k = 0; k < 10000; k++) /* back: the pairs those moves broke come back */
            pos[k] = 14 * k + (k & 3);
        move_both(s1, s2, &m, ids1, pos, 10000, 0.0, 0);
        update_both(e1, s1, s2, &m);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s2, &st));
        TEST_ASSERT_EQUAL_UINT32(0, st.rebuilt);
        /* five more, touching the hundred: each takes a dense index after
           theirs, which must all be taken */
        for (k = 0; k < 5; k++)
            lattice_box(n + 100 + k, 0.0, b + 6 * k);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s1, b, 5, NULL, more1));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s2, b, 5, NULL, more2));
        TEST_ASSERT_EQUAL_MEMORY(more1, more2, sizeof more1);
        for (k = 0; k < 5; k++)
            m_add(&m, more1[k], b + 6 * k, 1, ~(uint64_t)0, 0, 0, 0);
        update_both(e1, s1, s2, &m);
        /* the bad batches below work on the first n objects */
        while (m.n > n) {
            locd_id id = m.o[m.n - 1].id;
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s1, &id, 1));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s2, &id, 1));
            m_remove(&m, id);
        }
        update_both(e1, s1, s2, &m);
    }
    /* bad batches of the whole scene */
    for (k = 0; k < n; k++) { /* odd ones 2 up in y: applied, the batch would change the pairs */
        mv[k] = ids1[k];
        memcpy(b + 6 * k, m.o[k].box, 6 * sizeof *b);
        b[6 * k + 1] += (k & 1) ? 2.0 : 0.0, b[6 * k + 4] += (k & 1) ? 2.0 : 0.0;
    }
    mv[30000] = ids1[10];                       /* repeated */
    mv[50000] = ids1[50000] + ((uint64_t)7 << 32); /* stale: wrong serial */
    b[6 * 20000 + 1] = NAN;
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_STALE_ID, 50000);
    mv[50000] = ids1[50000];
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_DUPLICATE_ID, 30000);
    b[6 * 20000 + 1] = m.o[20000].box[1];
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_DUPLICATE_ID, 30000); /* the only fault */
    mv[30000] = ids1[30000];
    mv[100000] = ids1[10]; /* repeated across the two threads' halves */
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_DUPLICATE_ID, 100000);
    mv[100000] = ids1[100000];
    b[6 * 40000 + 4] = NAN;
    b[6 * 45000 + 0] = b[6 * 45000 + 3] + 1.0;
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_NONFINITE, 40000);
    b[6 * 40000 + 4] = m.o[40000].box[4];
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_INVERTED_BOX, 45000);
    /* put right, the same batch moves (and changes the pairs) */
    b[6 * 45000 + 0] = m.o[45000].box[0];
    /* The batch's ids ascend, which lets the pool skip the repeat check
       (move.c): one repeat breaks that, at the threads' split or inside a
       range. */
    mv[half] = mv[half - 1];
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_DUPLICATE_ID, half);
    mv[half] = ids1[half];
    mv[1001] = mv[1000];
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_DUPLICATE_ID, 1001);
    mv[1001] = ids1[1001];
    for (k = 0; k < n; k++)
        memcpy(m.o[k].box, b + 6 * k, 6 * sizeof *b);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s1, mv, b, n));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s2, mv, b, n));
    update_both(e1, s1, s2, &m);
    locd_scene_destroy(s1);
    locd_scene_destroy(s2);
    locd_engine_destroy(e1);
    locd_engine_destroy(e2);
    free(b), free(ids1), free(ids2), free(mv), free(pos), free(m.o), free(m.pairs);
}

/* Boxes of positions pos[0, cnt) for whole_scene_moves_in_slot_order: the
 * lattice's box of each object shifted along x by a quarter times 0 to 3,
 * from ts_next (floats exactly; which neighbours touch depends on the
 * draws, so a box written to another slot changes the pairs). */
static void jitter_boxes(model *m, const locd_id *ids, const size_t *pos, size_t cnt, ts_rng *r, locd_id *mv,
                         float *f)
{
    size_t i;
    int a;
    for (i = 0; i < cnt; i++) {
        double b[6], dx = 0.25 * (double)(ts_next(r) & 3);
        lattice_box(pos[i], 0.0, b);
        b[0] += dx, b[3] += dx;
        mv[i] = ids[pos[i]];
        for (a = 0; a < 6; a++)
            f[6 * i + a] = (float)b[a];
        memcpy(m->o[pos[i]].box, b, sizeof b);
    }
}

/* A float move of every object in slot order copies the boxes to the
 * spare array while it checks them, then swaps the arrays (move.c). The
 * swap must follow a good batch only; the spare it leaves (the old boxes)
 * must never be read as the boxes; a bad batch written half into the spare
 * changes nothing; and the batches that are not in slot order, or not of
 * every object, write the boxes as before. */
static void whole_scene_moves_in_slot_order(void)
{
    const size_t n = 120000;
    locd_engine *e1 = new_engine(1, NULL), *e2 = new_engine(2, NULL);
    locd_scene *s1 = NULL, *s2 = NULL;
    locd_id *ids1 = malloc(n * sizeof *ids1), *ids2 = malloc(n * sizeof *ids2), *mv = malloc(n * sizeof *mv);
    size_t *pos = malloc(n * sizeof *pos), k;
    float *f = malloc(n * 6 * sizeof *f);
    double b[6];
    model m;
    ts_rng r;
    int a, round;
    memset(&m, 0, sizeof m);
    ts_seed(&r, 616);
    for (k = 0; k < n; k++) {
        lattice_box(k, 0.0, b);
        for (a = 0; a < 6; a++)
            f[6 * k + a] = (float)b[a];
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e1, NULL, &s1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e2, NULL, &s2));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s1, f, n, NULL, ids1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s2, f, n, NULL, ids2));
    TEST_ASSERT_EQUAL_MEMORY(ids1, ids2, n * sizeof *ids1);
    for (k = 0; k < n; k++) {
        lattice_box(k, 0.0, b);
        m_add(&m, ids1[k], b, 1, ~(uint64_t)0, 0, 0, 0);
    }
    update_both(e1, s1, s2, &m);
    /* in slot order, three times: the arrays swap back and forth */
    for (k = 0; k < n; k++)
        pos[k] = k;
    for (round = 0; round < 3; round++) {
        if (round == 1) { /* some slots dirty already: the move counts only the others as new to the
                             dirty list, and sets every slot's flag */
            size_t few[3] = {0, 60001, n - 1};
            jitter_boxes(&m, ids1, few, 3, &r, mv, f);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s1, mv, f, 3));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s2, mv, f, 3));
        }
        jitter_boxes(&m, ids1, pos, n, &r, mv, f);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s1, mv, f, n));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s2, mv, f, n));
        update_both(e1, s1, s2, &m);
        if (round == 1) { /* a few moved after (one at the threads' split): every slot must have left
                             the dirty list, or its move would be missed */
            size_t few[2] = {n / 2, 70000};
            locd_scene_stats st;
            locd_scene_stats_init(&st);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s2, &st));
            TEST_ASSERT_EQUAL_UINT64(n, st.moved);
            jitter_boxes(&m, ids1, few, 2, &r, mv, f);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s1, mv, f, 2));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s2, mv, f, 2));
            update_both(e1, s1, s2, &m);
            locd_scene_stats_init(&st);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s2, &st));
            TEST_ASSERT_EQUAL_UINT64(2, st.moved);
        }
    }
    /* a bad batch in slot order: the spare takes the boxes up to the bad
       one (in each thread's range), and nothing changes */
    {
        model keep = m;
        keep.o = malloc(n * sizeof *keep.o);
        memcpy(keep.o, m.o, n * sizeof *keep.o);
        jitter_boxes(&keep, ids1, pos, n, &r, mv, f);
        f[6 * 90000 + 2] = NAN;
        bad_move_both(s1, s2, mv, f, 0, n, LOCD_ERR_NONFINITE, 90000);
        /* the ids ascending but one naming the next slot with its own serial
           (the slots' ids are consecutive: the move checks them without
           reading them) */
        f[6 * 90000 + 2] = f[6 * 90000 + 5] - 0.001f;
        mv[70000] += 1;
        bad_move_both(s1, s2, mv, f, 0, n, LOCD_ERR_STALE_ID, 70000);
        mv[70000] -= 1;
        /* an id twice: the batch no longer ascends, and the stamps find it */
        mv[50000] = mv[50001];
        bad_move_both(s1, s2, mv, f, 0, n, LOCD_ERR_DUPLICATE_ID, 50001);
        mv[50000] = ids1[50000];
        free(keep.o);
    }
    /* a fifth of the objects, then (from scratch) every box is read: the
       others must be the last good batch's boxes, not the spare's */
    for (k = 0; k < n / 5; k++)
        pos[k] = 5 * k;
    jitter_boxes(&m, ids1, pos, n / 5, &r, mv, f);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s1, mv, f, n / 5));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s2, mv, f, n / 5));
    update_both(e1, s1, s2, &m);
    /* every object in reverse slot order (the spare is written, not
       swapped), then in slot order again */
    for (k = 0; k < n; k++)
        pos[k] = n - 1 - k;
    for (round = 0; round < 2; round++) {
        jitter_boxes(&m, ids1, pos, n, &r, mv, f);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s1, mv, f, n));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s2, mv, f, n));
        update_both(e1, s1, s2, &m);
        for (k = 0; k < n; k++)
            pos[k] = k;
    }
    /* one object removed: a slot is not live, so no batch is of every slot */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s1, &ids1[7], 1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s2, &ids1[7], 1));
    m_remove(&m, ids1[7]); /* the model's last object takes position 7 */
    update_both(e1, s1, s2, &m);
    for (k = 0; k + 1 < n; k++)
        mv[k] = m.o[k].id;
    for (k = 0; k + 1 < n; k++) {
        m.o[k].box[0] += 0.125, m.o[k].box[3] -= 0.125;
        for (a = 0; a < 6; a++)
            f[6 * k + a] = (float)m.o[k].box[a];
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s1, mv, f, n - 1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s2, mv, f, n - 1));
    update_both(e1, s1, s2, &m);
    locd_scene_destroy(s1);
    locd_scene_destroy(s2);
    locd_engine_destroy(e1);
    locd_engine_destroy(e2);
    free(f), free(ids1), free(ids2), free(mv), free(pos), free(m.o), free(m.pairs);
}

/* The pairs of boxes f[0, n) as rows of ids[] (ascending with the index),
 * found by the engine's own find: a reference that shares no code with
 * the scene's kept entry list or near-pair list. With `grouped` > 0, less
 * the pairs of two objects whose index is a multiple of it (one group);
 * less the pairs of two objects from index first_static on (static). */
static locd_id *engine_rows_filtered(locd_engine *e, const float *f, const locd_id *ids, size_t n, uint32_t grouped,
                                     size_t first_static, size_t *count)
{
    locd_pairs *p = NULL;
    const uint32_t *v;
    locd_id *rows;
    size_t k, np, w = 0;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_find_pairs_f32(e, f, n, LOCD_FIND_SORTED, p));
    np = locd_pairs_count(p), v = locd_pairs_data(p);
    rows = malloc((np + 1) * 2 * sizeof *rows);
    for (k = 0; k < np; k++)
        if ((!grouped || v[2 * k] % grouped || v[2 * k + 1] % grouped) &&
            (v[2 * k] < first_static || v[2 * k + 1] < first_static))
            rows[2 * w] = ids[v[2 * k]], rows[2 * w + 1] = ids[v[2 * k + 1]], w++;
    locd_pairs_destroy(p);
    *count = w;
    return rows;
}

static locd_id *engine_rows(locd_engine *e, const float *f, const locd_id *ids, size_t n, uint32_t grouped,
                            size_t *count)
{
    return engine_rows_filtered(e, f, ids, n, grouped, n, count);
}

/* Rows of a (sorted) not in b (sorted), into out; returns how many. */
static size_t rows_minus(const locd_id *a, size_t na, const locd_id *b, size_t nb, locd_id *out)
{
    size_t i = 0, j = 0, w = 0;
    while (i < na) {
        int c = j == nb ? -1 : cmp_row(a + 2 * i, b + 2 * j);
        if (c < 0)
            out[2 * w] = a[2 * i], out[2 * w + 1] = a[2 * i + 1], w++, i++;
        else if (c == 0)
            i++, j++;
        else
            j++;
    }
    return w;
}

/* The scene's pairs, created and lost of its last update against the
 * reference rows now and before it. */
static void check_lists_against(locd_scene *s, const locd_id *now, size_t nnow, const locd_id *before,
                                size_t nbefore)
{
    const locd_id *p;
    size_t np, nw;
    locd_id *want = malloc((nnow + nbefore + 1) * 2 * sizeof *want);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s, &p, &np));
    same_rows("pairs against the engine's find", now, nnow, p, np);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_created(s, &p, &np));
    nw = rows_minus(now, nnow, before, nbefore, want);
    same_rows("created against the engine's finds", want, nw, p, np);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_lost(s, &p, &np));
    nw = rows_minus(before, nbefore, now, nnow, want);
    same_rows("lost against the engine's finds", want, nw, p, np);
    free(want);
}

/* An update, then its lists against the reference rows now and before. */
static void check_against(locd_scene *s, const locd_id *now, size_t nnow, const locd_id *before, size_t nbefore)
{
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS));
    check_lists_against(s, now, nnow, before, nbefore);
}

/* Boxes of edge `edge` at random corners in the unit cube, or (jitter)
 * each one's corner stepped by up to `jitter` on each axis. */
static void cube_boxes(ts_rng *r, float *f, size_t n, double edge, double jitter)
{
    size_t k;
    int a;
    for (k = 0; k < n; k++)
        for (a = 0; a < 3; a++) {
            f[6 * k + a] = jitter > 0.0 ? f[6 * k + a] + (float)((ts_uniform(r) - 0.5) * jitter)
                                        : (float)ts_uniform(r);
            f[6 * k + 3 + a] = f[6 * k + a] + (float)edge;
        }
}

/* A from-scratch update of 65,536 objects or more keeps its entries for the
 * next one (lib/scene/kept_list.c): it encodes every box again and merges
 * the entries of the objects whose cells changed into the sorted list. The
 * sequence takes each of its ways, with one thread and with two, and every
 * update is checked against the engine's own find: small steps (a merge),
 * every object far (more changes than the merge takes: all sorted), an
 * object out of the list's grid and back (a new grid), a fifth of the
 * objects moving (the band rule builds the scene's trees, and the list is
 * made again after), and one object removed (the slots are no longer the
 * engine's input: the engine's find). */
static void kept_entry_list_follows_whole_scene_moves(void)
{
    const size_t n = 70000;
    const double edge = 0.0153; /* about one pair an object */
    locd_engine *e1 = new_engine(1, NULL), *e2 = new_engine(2, NULL), *er = new_engine(2, NULL);
    locd_scene *s[2] = {NULL, NULL};
    locd_id *ids = malloc(n * sizeof *ids), *ids2 = malloc(n * sizeof *ids2), *before, *now;
    float *f = malloc(n * 6 * sizeof *f);
    size_t k, nbefore, nnow, nmove;
    ts_rng r;
    int frame, a, i;
    ts_seed(&r, 717);
    cube_boxes(&r, f, n, edge, 0.0);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e1, &kept_cfg, &s[0]));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e2, &kept_cfg, &s[1]));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s[0], f, n, NULL, ids));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s[1], f, n, NULL, ids2));
    TEST_ASSERT_EQUAL_MEMORY(ids, ids2, n * sizeof *ids);
    before = malloc(2 * sizeof *before), nbefore = 0;
    for (frame = 0; frame < 20; frame++) {
        /* frame 0 adds; 6 sends everything anywhere; 10 takes object 123 out
           of the grid, 13 back; 15 and 16 move a fifth; the others step */
        nmove = frame == 15 || frame == 16 ? n / 5 : frame == 0 ? 0 : n;
        for (k = 0; k < nmove; k++) {
            float *b = f + 6 * k;
            for (a = 0; a < 3; a++) {
                float d = frame == 6 ? (float)ts_uniform(&r) - b[a] : (float)((ts_uniform(&r) - 0.5) * 0.06 * edge);
                b[a] += d, b[a + 3] = b[a] + (float)edge;
            }
            if (k == 123 && (frame == 10 || frame == 13))
                for (a = 0; a < 6; a++)
                    b[a] += frame == 10 ? 5.0f : -5.0f;
        }
        for (i = 0; i < 2; i++)
            if (nmove)
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[i], ids, f, nmove));
        now = engine_rows(er, f, ids, n, 0, &nnow);
        TEST_ASSERT_TRUE(nnow > n / 2);
        for (i = 0; i < 2; i++)
            check_against(s[i], now, nnow, before, nbefore);
        free(before);
        before = now, nbefore = nnow;
    }
    /* one object removed: every slot is no longer live */
    for (i = 0; i < 2; i++)
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s[i], &ids[n - 1], 1));
    for (k = 0; k + 1 < n; k++)
        f[6 * k] += 0.25f * (float)edge, f[6 * k + 3] += 0.25f * (float)edge;
    for (i = 0; i < 2; i++)
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[i], ids, f, n - 1));
    now = engine_rows(er, f, ids, n - 1, 0, &nnow);
    for (i = 0; i < 2; i++)
        check_against(s[i], now, nnow, before, nbefore);
    free(before), free(now);
    locd_scene_destroy(s[0]);
    locd_scene_destroy(s[1]);
    locd_engine_destroy(e1);
    locd_engine_destroy(e2);
    locd_engine_destroy(er);
    free(f), free(ids), free(ids2);
}

/* An update of s checked against er's find of boxes f of ids[0, n) and
 * the rows before it (*before, which then become those rows); it must be
 * from scratch. Returns the pair count. */
static size_t check_from_scratch(locd_scene *s, locd_engine *er, const float *f, const locd_id *ids, size_t n,
                                 locd_id **before, size_t *nbefore)
{
    locd_scene_stats st;
    size_t nnow;
    locd_id *now = engine_rows(er, f, ids, n, 0, &nnow);
    check_against(s, now, nnow, *before, *nbefore);
    locd_scene_stats_init(&st);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s, &st));
    TEST_ASSERT_EQUAL_UINT32(1, st.rebuilt);
    free(*before);
    *before = now, *nbefore = nnow;
    return nnow;
}

/* Object k of the ends test is removed: the first and last `cut` ids, and
 * every other one in a band of 2 `band` ids around the middle. */
static int end_removed(size_t k, size_t n, size_t cut, size_t band)
{
    return k < cut || k >= n - cut || (k >= n / 2 - band && k < n / 2 + band && k % 2);
}

/* The created and lost lists of a from-scratch update are one merge of the
 * new rows with the previous ones, split over the pool by key range
 * (update.c, events_full): a thread's share of the previous set starts at
 * the key of the first row of its share of the new rows. Previous rows
 * whose first id is below the first live one, above the last one, or
 * between two threads' shares are lost rows too: objects removed at both
 * ends, and every other one in a band around the middle of the ids (where
 * the two shares meet). Also every pair gone at once and all back. Two
 * threads, more than 65,536 pairs, each update against the engine's find. */
static void from_scratch_events_at_the_ends(void)
{
    const size_t n = 70000, cut = 500, band = 3000;
    const double edge = 0.02; /* about two pairs an object */
    locd_engine *e = new_engine(2, NULL), *er = new_engine(2, NULL);
    locd_scene *s = NULL;
    locd_id *ids = malloc(n * sizeof *ids), *gone = malloc(n * sizeof *gone), *lid = malloc(n * sizeof *lid), *before;
    float *f = malloc(n * 6 * sizeof *f), *far = malloc(n * 6 * sizeof *far), *lf = malloc(n * 6 * sizeof *lf);
    size_t k, nbefore, nnow, ngone = 0, nlive = 0;
    ts_rng r;
    int frame, a;
    ts_seed(&r, 4242);
    cube_boxes(&r, f, n, edge, 0.0);
    for (k = 0; k < n; k++) /* a lattice of spacing 2 edge: no two boxes meet */
        for (a = 0; a < 3; a++) {
            const size_t c = a == 0 ? k % 42 : a == 1 ? k / 42 % 42 : k / (42 * 42);
            far[6 * k + a] = (float)(2.0 * edge * (double)c);
            far[6 * k + 3 + a] = far[6 * k + a] + (float)edge;
        }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s, f, n, NULL, ids));
    before = malloc(2 * sizeof *before), nbefore = 0;
    /* 0: the first update; 1: a step; 2: every pair gone; 3: all back */
    for (frame = 0; frame < 4; frame++) {
        const float *in = frame == 2 ? far : f;
        if (frame == 1)
            cube_boxes(&r, f, n, edge, 0.05 * edge);
        if (frame)
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s, ids, in, n));
        nnow = check_from_scratch(s, er, in, ids, n, &before, &nbefore);
        TEST_ASSERT_TRUE(frame == 2 ? nnow == 0 : nnow > 65536);
    }
    /* the first and last ids, and every other one in the band */
    for (k = 0; k < n; k++)
        if (end_removed(k, n, cut, band))
            gone[ngone++] = ids[k];
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, gone, ngone));
    for (frame = 0; frame < 2; frame++) {
        cube_boxes(&r, f, n, edge, 0.05 * edge);
        nlive = 0;
        for (k = 0; k < n; k++)
            if (!end_removed(k, n, cut, band)) {
                memcpy(lf + 6 * nlive, f + 6 * k, 6 * sizeof *f);
                lid[nlive++] = ids[k];
            }
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s, lid, lf, nlive));
        TEST_ASSERT_TRUE(check_from_scratch(s, er, lf, lid, nlive, &before, &nbefore) > 65536);
    }
    free(before);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    locd_engine_destroy(er);
    free(ids), free(gone), free(lid), free(f), free(far), free(lf);
}

/* A move of every object in slot order encodes the boxes for the next
 * update into the engine's packed-box buffer as it reads them (move.c,
 * kept_list.c). That update must encode them again when anything could
 * have written that buffer or changed a box since: another scene's move or
 * update on the same engine, a find of the engine, a later move of a few
 * objects. Two scenes share one two-thread engine; every update against
 * another engine's find. */
static void whole_scene_move_encodes_for_the_update(void)
{
    const size_t n = 70000, few = 100;
    const double edge = 0.0153, step = 0.06 * edge; /* about one pair an object; a small step */
    locd_engine *e2 = new_engine(2, NULL), *er = new_engine(2, NULL);
    locd_scene *s[2] = {NULL, NULL};
    locd_id *ids[2], *before[2] = {NULL, NULL}, *now;
    locd_pairs *p = NULL;
    float *f[2];
    size_t nbefore[2] = {0, 0}, nnow, k;
    ts_rng r;
    int round, i, order;
    ts_seed(&r, 919);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    for (i = 0; i < 2; i++) {
        ids[i] = malloc(n * sizeof *ids[i]), f[i] = malloc(n * 6 * sizeof *f[i]);
        cube_boxes(&r, f[i], n, edge, 0.0);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e2, &kept_cfg, &s[i]));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s[i], f[i], n, NULL, ids[i]));
    }
    /* rounds: 0 the first updates; then scene 0 moves every object and
       1 nothing else happens (the move's encode is the update's), 2 scene 1
       moves every object too, 3 the engine finds the pairs of scene 1's
       boxes, 4 scene 0 moves every object again, 5 scene 0 moves a few
       objects elsewhere, 6 scene 1 moves every object and updates first */
    for (round = 0; round < 7; round++) {
        const int both = round == 0 || round == 2 || round == 6;
        if (round > 0) {
            cube_boxes(&r, f[0], n, edge, step);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[0], ids[0], f[0], n));
        }
        if (round == 2 || round == 6) {
            cube_boxes(&r, f[1], n, edge, step);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[1], ids[1], f[1], n));
        } else if (round == 3) {
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_find_pairs_f32(e2, f[1], n, 0, p));
        } else if (round == 4) {
            cube_boxes(&r, f[0], n, edge, step);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[0], ids[0], f[0], n));
        } else if (round == 5) {
            for (k = 0; k < few * 6; k++) /* elsewhere in the list's grid (out of it, the list is made again) */
                f[0][k] = k % 6 < 3 ? (float)(0.1 + 0.8 * ts_uniform(&r)) : f[0][k - 3] + (float)edge;
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[0], ids[0], f[0], few));
        }
        for (order = 0; order < (both ? 2 : 1); order++) {
            i = round == 6 ? 1 - order : order;
            now = engine_rows(er, f[i], ids[i], n, 0, &nnow);
            TEST_ASSERT_TRUE(nnow > n / 2);
            check_against(s[i], now, nnow, before[i], nbefore[i]);
            free(before[i]);
            before[i] = now, nbefore[i] = nnow;
        }
    }
    for (i = 0; i < 2; i++) {
        locd_scene_destroy(s[i]);
        free(before[i]), free(ids[i]), free(f[i]);
    }
    locd_pairs_destroy(p);
    locd_engine_destroy(e2);
    locd_engine_destroy(er);
}

/* With the kept entry list, the pair order takes the sweep's pairs as it
 * finds them, into bucket regions sized from the previous update's counts
 * (lib/scene/pair_order.c). The pair counts here jump between updates:
 * a bucket outgrows its region (its extra pairs spill), the spill area
 * overflows (the list is swept again and its gathered pairs ordered), the
 * counts fall back; with a group filter (pairs dropped in the sink) and
 * without, on one thread and two. Every update against the engine's find. */
static void kept_entry_list_pair_counts_jump(void)
{
    const size_t n = 70000;
    const double edge = 0.0153;
    locd_engine *e[2], *er = new_engine(2, NULL);
    locd_scene *s[2] = {NULL, NULL};
    locd_id *ids = malloc(n * sizeof *ids), *ids2 = malloc(n * sizeof *ids2), *before, *now;
    float *f = malloc(n * 6 * sizeof *f), *home = malloc(n * 6 * sizeof *f);
    uint64_t *groups = malloc(n * sizeof *groups);
    size_t k, nbefore, nnow;
    ts_rng r;
    int frame, a, i;
    uint32_t grouped;
    for (grouped = 0; grouped <= 5; grouped += 5) {
        ts_seed(&r, 919 + grouped);
        cube_boxes(&r, home, n, edge, 0.0);
        memcpy(f, home, n * 6 * sizeof *f);
        for (i = 0; i < 2; i++) {
            e[i] = new_engine((uint32_t)i + 1, NULL);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e[i], &kept_cfg, &s[i]));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s[i], f, n, NULL, i ? ids2 : ids));
        }
        TEST_ASSERT_EQUAL_MEMORY(ids, ids2, n * sizeof *ids);
        if (grouped) {
            for (k = 0; k < n; k++)
                groups[k] = k % grouped ? 0 : 7;
            for (i = 0; i < 2; i++)
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s[i], ids, n, NULL, NULL, groups));
        }
        before = malloc(2 * sizeof *before), nbefore = 0;
        for (frame = 0; frame < 9; frame++) {
            /* 2, 3: the first 120 objects (one bucket) in one spot, about
               7,000 pairs where the bucket had a few hundred: they spill;
               5, 6: the first 1,500 in one spot, a million pairs: the spill
               area overflows, then the regions are that large; 8: all home */
            const size_t crowd = frame == 2 || frame == 3 ? 120 : frame == 5 || frame == 6 ? 1500 : 0;
            for (k = 0; frame && k < n; k++) {
                float *b = f + 6 * k;
                for (a = 0; a < 3; a++) {
                    b[a] = k < crowd ? 0.5f + (float)((ts_uniform(&r) - 0.5) * edge)
                                     : home[6 * k + a] + (float)((ts_uniform(&r) - 0.5) * 0.06 * edge);
                    b[a + 3] = b[a] + (float)edge;
                }
            }
            if (frame)
                for (i = 0; i < 2; i++)
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[i], ids, f, n));
            now = engine_rows(er, f, ids, n, grouped, &nnow);
            if (crowd) /* every two of the crowd overlap (but for a few of one group) */
                TEST_ASSERT_TRUE(nnow > crowd * (crowd - 1) / 2 * 9 / 10);
            for (i = 0; i < 2; i++)
                check_against(s[i], now, nnow, before, nbefore);
            free(before);
            before = now, nbefore = nnow;
        }
        free(before);
        for (i = 0; i < 2; i++) {
            locd_scene_destroy(s[i]);
            locd_engine_destroy(e[i]);
        }
    }
    locd_engine_destroy(er);
    free(f), free(home), free(ids), free(ids2), free(groups);
}

/* Every allocation of a move of every object and of the update after it
 * fails in turn, on a scene large enough for the kept entry list (small
 * steps: its merge; every object far: its full sort; after a failure: a
 * list made again). The failing call gives LOCD_ERR_NO_MEMORY (or absorbs
 * the failure) and the next working update's pairs, created and lost are
 * the engine's own find's, against the last working update. */
static void whole_scene_allocation_failures(const locd_scene_config *cfg, const char *what, int min_failed,
                                            int min_absorbed)
{
    const size_t n = 70000;
    const double edge = 0.0153;
    locd_engine *e = new_engine(2, fa_allocator()), *er = new_engine(2, NULL);
    locd_scene *s = NULL;
    locd_id *ids = malloc(n * sizeof *ids), *before, *now;
    float *f = malloc(n * 6 * sizeof *f), *g = malloc(n * 6 * sizeof *g);
    size_t k, nbefore, nnow;
    ts_rng r;
    int a, far, failed_calls = 0, absorbed = 0;
    uint64_t fail;
    ts_seed(&r, 818);
    cube_boxes(&r, f, n, edge, 0.0);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, cfg, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s, f, n, NULL, ids));
    before = engine_rows(er, f, ids, n, 0, &nbefore);
    check_against(s, before, nbefore, NULL, 0);
    for (far = 0; far < 2; far++)
        for (fail = 1;; fail++) {
            locd_status st;
            fa_counts c;
            int moved;
            for (k = 0; k < n; k++)
                for (a = 0; a < 3; a++) {
                    float d = far ? (float)ts_uniform(&r) - f[6 * k + a] : (float)((ts_uniform(&r) - 0.5) * 0.06 * edge);
                    g[6 * k + a] = f[6 * k + a] + d, g[6 * k + 3 + a] = g[6 * k + a] + (float)edge;
                }
            fa_arm(fail, 0);
            st = locd_scene_move_f32(s, ids, g, n);
            moved = st == LOCD_OK;
            if (moved)
                st = locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS);
            fa_counts_get(&c);
            fa_arm(0, 0);
            if (moved)
                memcpy(f, g, n * 6 * sizeof *f);
            now = engine_rows(er, f, ids, n, 0, &nnow);
            absorbed += st == LOCD_OK && c.failures > 0;
            if (st == LOCD_OK) { /* no failure, or one absorbed: the update is exact */
                TEST_ASSERT_TRUE(moved);
                check_lists_against(s, now, nnow, before, nbefore);
            } else { /* the next working update takes the failed one's place */
                TEST_ASSERT_EQUAL_INT(LOCD_ERR_NO_MEMORY, st);
                failed_calls++;
                check_against(s, now, nnow, before, nbefore);
            }
            free(before);
            before = now, nbefore = nnow;
            if (c.failures == 0)
                break;
        }
    LT_PRINT("%s: %d failed calls, each left the scene as before; %d failures absorbed\n", what, failed_calls,
             absorbed);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    locd_engine_destroy(er);
    free(before), free(f), free(g), free(ids);
    /* the buffers are kept from frame to frame: a move and an update of a
       warm scene allocate a few blocks only, but some */
    TEST_ASSERT_TRUE(failed_calls >= min_failed);
    TEST_ASSERT_TRUE(absorbed >= min_absorbed);
}

static void kept_entry_list_allocation_failures(void)
{
    whole_scene_allocation_failures(&kept_cfg, "kept entry list", 4, 0);
}

/* The same with the near-pair list (near_list.c): its build failing is
 * absorbed (the update goes from scratch without it: five of this
 * sequence's failures fall in builds); a frame's pass failing fails the
 * update and drops the list. */
static void near_list_allocation_failures(void)
{
    whole_scene_allocation_failures(NULL, "near-pair list", 1, 4);
}

/* What a frame of near_list_follows_whole_scene_moves does, and which
 * path its update must take. */
typedef struct near_frame {
    const char *what;
    int near; /* 1: from the near-pair list; 0: from scratch (with or without building it) */
} near_frame;

/* The near-pair list (near_list.c) serves whole-scene moves of small
 * steps: a from-scratch update builds it, the next ones take it while every
 * box stays inside its fat box. Three scenes (1, 2 and 3 threads: the pass's
 * outputs closed up from one, two and three regions) go through each way,
 * a quarter of the objects static and each update checked against the
 * engine's own find (pairs, created, lost) and the path its statistics show:
 * steps; one object out of its fat box (built again); every box shrunk to
 * a point and back (a set that falls and grows past the rows' regions and
 * the events': the rows written again, the events from the diff); a group
 * filter set (built again with it); every object far twice (the second list
 * served nothing: the next builds wait); the last object removed, then one
 * added in its slot (ids ascending with a gap: the rows' ids read, not
 * computed); an object removed (no list). */
static void near_list_follows_whole_scene_moves(void)
{
    static const near_frame plan[] = {
        {"first update", 0},   {"step: build", 0},         {"step", 1},           {"one object out", 0},
        {"points", 1},         {"back", 1},                {"filter: build", 0},  {"step", 1},
        {"all far: build", 0}, {"all far: no build", 0},   {"step: wait", 0},     {"step: build", 0},
        {"step", 1},           {"step", 1},                {"remove the last", 0}, {"add one: build", 0},
        {"step", 1},           {"remove one", 0},
    };
    const size_t n = 72000, nd = n - n / 4, nplan = sizeof plan / sizeof plan[0];
    const double edge = 0.0153;
    locd_engine *e[3], *er = new_engine(2, NULL);
    locd_scene *s[3];
    locd_scene_add_options o;
    locd_id *ids = malloc(n * sizeof *ids), *ids2 = malloc(n * sizeof *ids2), *before, *now;
    float *f = malloc(n * 6 * sizeof *f), *pt = malloc(n * 6 * sizeof *pt), last[6];
    uint64_t *groups = malloc(n * sizeof *groups);
    size_t k, nbefore, nnow, live = n;
    uint32_t grouped = 0;
    ts_rng r;
    int i, a;
    size_t frame;
    ts_seed(&r, 1313);
    cube_boxes(&r, f, n, edge, 0.0);
    locd_scene_add_options_init(&o);
    o.flags = LOCD_OBJECT_STATIC;
    for (i = 0; i < 3; i++) {
        e[i] = new_engine((uint32_t)i + 1, NULL);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e[i], NULL, &s[i]));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s[i], f, nd, NULL, i ? ids2 : ids));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s[i], f + 6 * nd, n - nd, &o, (i ? ids2 : ids) + nd));
        if (i)
            TEST_ASSERT_EQUAL_MEMORY(ids, ids2, n * sizeof *ids);
    }
    before = malloc(2 * sizeof *before), nbefore = 0;
    for (frame = 0; frame < nplan; frame++) {
        const char *w = plan[frame].what;
        size_t moved = nd;
        if (!strcmp(w, "points")) {
            memcpy(pt, f, n * 6 * sizeof *f);
            for (k = 0; k < nd; k++)
                for (a = 0; a < 3; a++)
                    f[6 * k + a] = f[6 * k + 3 + a] = 0.5f * (f[6 * k + a] + f[6 * k + 3 + a]);
        } else if (!strcmp(w, "back")) {
            memcpy(f, pt, n * 6 * sizeof *f);
        } else if (!strncmp(w, "all far", 7)) {
            cube_boxes(&r, f, nd, edge, 0.0);
        } else if (frame) {
            cube_boxes(&r, f, nd, edge, 0.06 * edge); /* steps of up to 0.03 edge: a fat box holds two */
        } else {
            moved = 0;
        }
        if (!strcmp(w, "one object out"))
            for (a = 0; a < 3; a++)
                f[6 * 777 + a] += (float)edge, f[6 * 777 + 3 + a] += (float)edge;
        if (!strcmp(w, "filter: build")) {
            grouped = 5;
            for (k = 0; k < n; k++)
                groups[k] = k % grouped ? 0 : 7;
        }
        if (!strcmp(w, "add one: build")) /* (the last slot again, with a new serial: ids ascend, with a gap) */
            memcpy(f + 6 * (n - 1), last, sizeof last);
        for (i = 0; i < 3; i++) {
            if (!strcmp(w, "remove the last"))
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s[i], &ids[n - 1], 1));
            if (!strcmp(w, "add one: build")) {
                locd_id id;
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s[i], last, 1, &o, &id));
                TEST_ASSERT_TRUE(id > ids[n - 2]);
                if (i == 0)
                    ids[n - 1] = id;
                TEST_ASSERT_EQUAL_UINT64(ids[n - 1], id);
            }
            if (grouped && !strcmp(w, "filter: build"))
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s[i], ids, n, NULL, NULL, groups));
            if (!strcmp(w, "remove one"))
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s[i], &ids[nd - 1], 1));
            if (moved)
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[i], ids, f, !strcmp(w, "remove one") ? nd - 1 : nd));
        }
        if (!strcmp(w, "remove one") || !strcmp(w, "remove the last")) { /* the reference without it: far away */
            const size_t gone = !strcmp(w, "remove one") ? nd - 1 : n - 1;
            memcpy(last, f + 6 * gone, sizeof last);
            for (a = 0; a < 3; a++)
                f[6 * gone + a] = 100.0f, f[6 * gone + 3 + a] = 100.0f;
            live--;
        }
        if (!strcmp(w, "add one: build"))
            live++;
        now = engine_rows_filtered(er, f, ids, n, grouped, nd, &nnow);
        TEST_ASSERT_TRUE(!strcmp(w, "points") ? nnow < n / 8 : nnow > n / 2);
        for (i = 0; i < 3; i++) {
            locd_scene_stats st;
            check_against(s[i], now, nnow, before, nbefore);
            locd_scene_stats_init(&st);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s[i], &st));
            TEST_ASSERT_EQUAL_UINT64(live, st.objects);
            if (plan[frame].near != (st.rebuilt == 0 && st.coasted == st.moved && st.entries == 0))
                LT_FAIL("frame %zu (%s), %d threads: %s the near-pair list", frame, w, i + 1,
                        plan[frame].near ? "not from" : "from");
        }
        free(before);
        before = now, nbefore = nnow;
    }
    free(before);
    for (i = 0; i < 3; i++) {
        locd_scene_destroy(s[i]);
        locd_engine_destroy(e[i]);
    }
    locd_engine_destroy(er);
    free(f), free(pt), free(ids), free(ids2), free(groups);
}

/* Adds n boxes (dynamic, or static) to scene and model. */
static void add_boxes(locd_scene *s, model *m, const double *b, size_t n, int stat, locd_id *ids)
{
    locd_scene_add_options o;
    size_t k;
    locd_scene_add_options_init(&o);
    o.flags = stat ? LOCD_OBJECT_STATIC : 0;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, n, &o, ids));
    for (k = 0; k < n; k++)
        m_add(m, ids[k], b + 6 * k, 1, ~(uint64_t)0, 0, 0, stat);
}

static void move_box(locd_scene *s, model *m, locd_id id, const double *b)
{
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, &id, b, 1));
    memcpy(m_find(m, id)->box, b, 6 * sizeof *b);
}

/* Moves every object of the model to its box in the model (so that the
 * update finds its pairs from scratch), updates, checks, and checks that
 * it was from scratch. */
static void update_all_from_scratch(locd_scene *s, model *m)
{
    size_t k;
    locd_scene_stats st;
    for (k = 0; k < m->n; k++)
        move_box(s, m, m->o[k].id, m->o[k].box);
    check_update(s, m);
    locd_scene_stats_init(&st);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s, &st));
    TEST_ASSERT_EQUAL_UINT32(1, st.rebuilt);
}

/* The from-scratch path gives the engine the float copies of the boxes
 * only when every live box is floats exactly. Boxes 1e-12 apart, which
 * touch once rounded to floats, go from not floats to floats and back, on
 * slots in id order and, after removals and adds, out of it. */
/* A from-scratch update keeps what it learns of every slot (ids in slot
 * order and consecutive; no filter that can drop a pair) until an add, a
 * remove or a set_filter changes it (scene.h, order_known and
 * filter_known): each change here comes between two from-scratch updates
 * of a scene that moves only, and each update is checked against the
 * model. */
static void from_scratch_follows_adds_removes_and_filters(void)
{
    locd_engine *e = new_engine(2, NULL);
    locd_scene *s = NULL;
    const size_t n = 3000;
    double *b = malloc(n * 6 * sizeof *b);
    locd_id *ids = malloc(n * sizeof *ids);
    uint64_t *grp = malloc(n * sizeof *grp);
    model m;
    world w;
    size_t k;
    memset(&m, 0, sizeof m);
    w = world_make(8080, 60.0, 3.0, 0);
    for (k = 0; k < n; k++)
        random_box(&w, b + 6 * k);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    add_boxes(s, &m, b, n, 0, ids); /* one batch: ids consecutive in slot order */
    update_all_from_scratch(s, &m);
    update_all_from_scratch(s, &m);
    /* a group on every third object: pairs among them go */
    for (k = 0; k < n; k++)
        grp[k] = k % 3 == 0 ? 7 : 0;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s, ids, n, NULL, NULL, grp));
    for (k = 0; k < n; k++)
        m_find(&m, ids[k])->group = grp[k];
    update_all_from_scratch(s, &m);
    /* groups off again, then a mask that drops every pair with category 2 */
    for (k = 0; k < n; k++)
        grp[k] = 0;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s, ids, n, NULL, NULL, grp));
    for (k = 0; k < n; k++)
        m_find(&m, ids[k])->group = 0;
    update_all_from_scratch(s, &m);
    /* two static objects on one box: their pair must not be reported */
    {
        locd_id st_ids[2];
        random_box(&w, b);
        memcpy(b + 6, b, 6 * sizeof *b);
        add_boxes(s, &m, b, 2, 1, st_ids);
    }
    update_all_from_scratch(s, &m);
    {
        uint64_t cat = 2, mask = ~(uint64_t)2;
        locd_id some[40];
        for (k = 0; k < 40; k++)
            some[k] = ids[k * 70];
        for (k = 0; k < 40; k++) {
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s, &some[k], 1, &cat, &mask, NULL));
            m_find(&m, some[k])->cat = cat, m_find(&m, some[k])->mask = mask;
        }
    }
    update_all_from_scratch(s, &m);
    /* removed objects: slot order is no longer id order once their slots
       are free, then new objects fill the slots with later ids */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, ids + 100, 50));
    for (k = 0; k < 50; k++)
        m_remove(&m, ids[100 + k]);
    update_all_from_scratch(s, &m);
    update_all_from_scratch(s, &m);
    for (k = 0; k < 30; k++)
        random_box(&w, b + 6 * k);
    add_boxes(s, &m, b, 30, 0, ids + 100);
    update_all_from_scratch(s, &m);
    update_all_from_scratch(s, &m);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(b), free(ids), free(grp), free(m.o), free(m.pairs);
}

/* An update reads a dirty list of an eighth of the slots or more as the
 * flags of every slot (update.c, dirty_dense); a shorter one as the list.
 * Either way stats.moved counts the live objects of the list, and every
 * DIRTY flag is cleared: one left set would keep the next move of its
 * object off the list, and that object's new pairs out of the set. A dense
 * update with moved, removed, added and re-filtered objects, then sparse
 * ones that move objects of each kind again, each checked against the
 * model. */
static void dense_and_sparse_dirty_lists(void)
{
    locd_engine *e = new_engine(2, NULL);
    locd_scene *s = NULL;
    const size_t n = 2000;
    double *b = malloc(n * 6 * sizeof *b);
    locd_id *ids = malloc(n * sizeof *ids), gone[100], added[50], refiltered[10];
    uint64_t cat[10];
    model m;
    world w;
    size_t k, round;
    locd_scene_stats st;
    memset(&m, 0, sizeof m);
    w = world_make(4242, 50.0, 3.0, 0);
    for (k = 0; k < n; k++)
        random_box(&w, b + 6 * k);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    add_boxes(s, &m, b, n, 0, ids);
    check_update(s, &m);
    for (k = 0; k < 600; k++) { /* 600 moved, the first 100 of them then removed */
        random_box(&w, b);
        move_box(s, &m, ids[3 * k], b);
    }
    for (k = 0; k < 100; k++)
        gone[k] = ids[3 * k];
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, gone, 100));
    for (k = 0; k < 100; k++)
        m_remove(&m, gone[k]);
    for (k = 0; k < 50; k++)
        random_box(&w, b + 6 * k);
    add_boxes(s, &m, b, 50, 0, added);
    for (k = 0; k < 10; k++) /* unmoved, re-filtered to what they had: dirty all the same */
        refiltered[k] = ids[3 * k + 1], cat[k] = 1;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s, refiltered, 10, cat, NULL, NULL));
    check_update(s, &m);
    locd_scene_stats_init(&st);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s, &st));
    TEST_ASSERT_EQUAL_UINT64(500 + 50 + 10, st.moved);
    for (round = 0; round < 3; round++) { /* sparse: one moved, one added and one re-filtered object each */
        const locd_id again[3] = {ids[3 * (100 + round * 150)], added[round * 20], refiltered[round * 4]};
        for (k = 0; k < 3; k++) {
            random_box(&w, b);
            move_box(s, &m, again[k], b);
        }
        check_update(s, &m);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s, &st));
        TEST_ASSERT_EQUAL_UINT64(3, st.moved);
    }
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(b), free(ids), free(m.o), free(m.pairs);
}

static void float_copies_follow_the_boxes(void)
{
    locd_engine *e = new_engine(2, NULL);
    locd_scene *s = NULL;
    model m;
    const size_t n = 100;
    double b[6 * 100];
    locd_id ids[100], bids[100];
    size_t k;
    int step;
    memset(&m, 0, sizeof m);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    for (k = 0; k < n; k++) { /* A: [2k, 2k + 1] on x */
        double *x = b + 6 * k;
        x[0] = 2.0 * (double)k, x[1] = 0, x[2] = 0, x[3] = 2.0 * (double)k + 1.0, x[4] = 1, x[5] = 1;
    }
    add_boxes(s, &m, b, n, 0, ids);
    for (k = 0; k < n; k++) { /* B: from just past A's end: no pair, but touching in floats */
        double *x = b + 6 * k;
        x[0] = 2.0 * (double)k + 1.0 + 1e-12, x[1] = 0, x[2] = 0, x[3] = 2.0 * (double)k + 1.5, x[4] = 1, x[5] = 1;
        TEST_ASSERT_TRUE((double)to_float(x[0]) != x[0]);
    }
    add_boxes(s, &m, b, n, 0, bids);
    check_update(s, &m);
    TEST_ASSERT_EQUAL_UINT64(0, m.npairs);
    for (step = 0; step < 6; step++) {
        /* steps 0, 2, 4: B on A's end (floats exactly: n pairs); 1, 3, 5: just past it */
        for (k = 0; k < n; k++) {
            m_obj *o = m_find(&m, bids[k]);
            if (o)
                o->box[0] = 2.0 * (double)k + 1.0 + (step % 2 ? 1e-12 : 0.0);
        }
        if (step == 4) /* one B past its A's end: one box not floats, the others are */
            m_find(&m, bids[7])->box[0] += 1e-12;
        update_all_from_scratch(s, &m);
        if (step % 2)
            TEST_ASSERT_EQUAL_UINT64(0, m.npairs);
        else
            TEST_ASSERT_TRUE(m.npairs > 0);
        if (step == 1) { /* out of id order: a removed A's slot taken by a new object */
            locd_id gone[10], fresh[10];
            for (k = 0; k < 10; k++) {
                gone[k] = ids[3 * k];
                m_remove(&m, gone[k]);
            }
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, gone, 10));
            check_update(s, &m);
            for (k = 0; k < 10; k++) {
                double *x = b + 6 * k;
                x[0] = 2.0 * (double)(3 * k), x[1] = 0.5, x[2] = 0, x[3] = 2.0 * (double)(3 * k) + 1.0, x[4] = 1, x[5] = 1;
            }
            add_boxes(s, &m, b, 10, 0, fresh);
            for (k = 0; k < 10; k++)
                ids[3 * k] = fresh[k];
            check_update(s, &m);
        }
    }
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o), free(m.pairs);
}

/* Identical boxes, touching faces, zero-size boxes, huge next to tiny, far
 * from the origin, -0, and a box that grows the root cube and comes back:
 * each update against the model, with queries. */
static void hard_cases(void)
{
    static const double scales[] = {1.0, 1e-6, 1e30, 3.5e-300};
    size_t si;
    for (si = 0; si < sizeof scales / sizeof scales[0]; si++) {
        const double u = scales[si];
        locd_engine *e = new_engine(2, NULL);
        locd_scene *s = NULL;
        model m;
        double b[6 * 64];
        locd_id ids[64];
        int i, a, step;
        memset(&m, 0, sizeof m);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
        /* 20 identical boxes */
        for (i = 0; i < 20; i++)
            for (a = 0; a < 3; a++)
                b[6 * i + a] = 1.0 * u, b[6 * i + 3 + a] = 2.0 * u;
        add_boxes(s, &m, b, 20, 0, ids);
        /* a lattice of touching unit boxes, some static */
        for (i = 0; i < 27; i++)
            for (a = 0; a < 3; a++) {
                int c = (i / (a == 0 ? 1 : a == 1 ? 3 : 9)) % 3;
                b[6 * i + a] = (3.0 + c) * u, b[6 * i + 3 + a] = (4.0 + c) * u;
            }
        add_boxes(s, &m, b, 14, 1, ids + 20);
        add_boxes(s, &m, b + 6 * 14, 13, 0, ids + 34);
        /* zero-size boxes on the lattice's corners and faces, -0 */
        for (i = 0; i < 6; i++)
            for (a = 0; a < 3; a++)
                b[6 * i + a] = b[6 * i + 3 + a] = (3.0 + (double)((i + a) % 4)) * u;
        b[0] = b[3] = -0.0;
        add_boxes(s, &m, b, 6, 0, ids + 47);
        /* huge next to tiny */
        for (a = 0; a < 3; a++) {
            b[a] = -1e3 * u, b[3 + a] = 1e3 * u;
            b[6 + a] = 3.5 * u, b[9 + a] = 3.5 * u + 1e-9 * u;
        }
        add_boxes(s, &m, b, 2, 0, ids + 53);
        check_update(s, &m);
        for (step = 0; step < 30; step++) {
            locd_id id = ids[(size_t)(step * 7) % 55];
            double nb[6], q[7];
            const m_obj *o = m_find(&m, id);
            memcpy(nb, o->box, sizeof nb);
            if (step % 10 == 3) { /* far out: the root cube must grow */
                for (a = 0; a < 6; a++)
                    nb[a] += 1e6 * u;
            } else if (step % 10 == 4) { /* and back */
                for (a = 0; a < 6; a++)
                    nb[a] -= 1e6 * u;
            } else { /* onto a neighbour's face */
                double d = (double)(step % 3) * 1.0 * u;
                for (a = 0; a < 6; a++)
                    nb[a] += d;
            }
            if (isfinite(nb[0]) && isfinite(nb[5]) && nb[0] <= nb[3] && nb[1] <= nb[4] && nb[2] <= nb[5])
                move_box(s, &m, id, nb);
            check_update(s, &m);
            for (a = 0; a < 3; a++)
                q[a] = 3.0 * u, q[a + 3] = 4.0 * u;
            check_query(s, &m, 0, q, ~(uint64_t)0);
            check_query(s, &m, 1, q + 3, ~(uint64_t)0);
            q[0] = 0.0, q[1] = 3.5 * u, q[2] = 3.5 * u, q[3] = 1.0, q[4] = 0.0, q[5] = 0.0, q[6] = 10.0 * u;
            check_query(s, &m, 2, q, ~(uint64_t)0);
        }
        locd_scene_destroy(s);
        locd_engine_destroy(e);
        free(m.o);
        free(m.pairs);
    }
}

/* The float32 entry points give what the float64 ones give for the same
 * (float-representable) values. */
/* A box over the whole scene, added first: its row run in the from-scratch
 * ordering is every other object, far past the insertion sort's few
 * (rebuild.c, sort_run). */
static void a_box_over_everything(void)
{
    locd_engine *e = new_engine(2, NULL);
    locd_scene *s = NULL;
    model m;
    world w;
    double b[6 * 301];
    locd_id ids[301];
    int k, a;
    memset(&m, 0, sizeof m);
    w = world_make(909, 50.0, 3.0, 0);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    for (a = 0; a < 3; a++)
        b[a] = -100.0, b[3 + a] = 100.0;
    for (k = 1; k < 301; k++)
        random_box(&w, b + 6 * k);
    add_boxes(s, &m, b, 301, 0, ids);
    check_update(s, &m);
    for (k = 0; k < 3; k++)
        update_all_from_scratch(s, &m);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o), free(m.pairs);
}

static void f32_entry_points_match_f64(void)
{
    locd_engine *e = new_engine(1, NULL);
    locd_scene *s32 = NULL, *s64 = NULL;
    world w;
    float f[6 * 200], q32[6], o32[3], d32[3];
    double b[6 * 200], q64[6], o64[3], d64[3];
    locd_id ids32[200], ids64[200], h32[200], h64[200];
    double t32[200], t64[200];
    size_t n32, n64, i;
    int k, a;
    memset(&w, 0, sizeof w);
    ts_seed(&w.r, 77);
    w.extent = 30.0, w.size = 3.0;
    for (i = 0; i < 6 * 200; i++) {
        if (i % 6 == 0)
            random_box(&w, b + i);
    }
    for (i = 0; i < 6 * 200; i++)
        f[i] = to_float(b[i]), b[i] = f[i];
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s32));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s64));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s32, f, 200, NULL, ids32));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s64, b, 200, NULL, ids64));
    TEST_ASSERT_EQUAL_MEMORY(ids32, ids64, sizeof ids32);
    for (k = 0; k < 40; k++) {
        if (k == 20) { /* moved through both entry points, updated */
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s32, ids32, f + 6 * 100, 100));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s64, ids64, b + 6 * 100, 100));
        }
        if (k % 10 == 0) {
            const locd_id *p32, *p64;
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s32, LOCD_SCENE_UPDATE_PAIRS));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s64, LOCD_SCENE_UPDATE_PAIRS));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s32, &p32, &n32));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s64, &p64, &n64));
            same_rows("f32 against f64", p64, n64, p32, n32);
        }
        random_box(&w, q64);
        for (a = 0; a < 6; a++)
            q32[a] = to_float(q64[a]), q64[a] = q32[a];
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_query_box_f32(s32, q32, ~(uint64_t)0, h32, 200, &n32));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_query_box_f64(s64, q64, ~(uint64_t)0, h64, 200, &n64));
        TEST_ASSERT_EQUAL_UINT64(n64, n32);
        if (n64)
            TEST_ASSERT_EQUAL_MEMORY(h64, h32, n64 * sizeof *h64);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_query_point_f32(s32, q32, 3, h32, 200, &n32));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_query_point_f64(s64, q64, 3, h64, 200, &n64));
        TEST_ASSERT_EQUAL_UINT64(n64, n32);
        if (n64)
            TEST_ASSERT_EQUAL_MEMORY(h64, h32, n64 * sizeof *h64);
        for (a = 0; a < 3; a++) {
            o32[a] = q32[a], o64[a] = q64[a];
            d32[a] = to_float((ts_uniform(&w.r) - 0.5) * 20.0), d64[a] = d32[a];
        }
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_raycast_f32(s32, o32, d32, 2.0, ~(uint64_t)0, h32, t32, 200, &n32));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_raycast_f64(s64, o64, d64, 2.0, ~(uint64_t)0, h64, t64, 200, &n64));
        TEST_ASSERT_EQUAL_UINT64(n64, n32);
        if (n64) {
            TEST_ASSERT_EQUAL_MEMORY(h64, h32, n64 * sizeof *h64);
            TEST_ASSERT_EQUAL_MEMORY(t64, t32, n64 * sizeof *t64);
        }
    }
    locd_scene_destroy(s32);
    locd_scene_destroy(s64);
    locd_engine_destroy(e);
}

/* Queries only read: two threads query one scene at once (TSan watches),
 * each getting what one thread alone gets. */
typedef struct query_job {
    const locd_scene *s;
    uint64_t hash;
    int failed;
} query_job;

/* Empty scenes: an update with no object, after every object was removed,
 * and after objects come back, at 1 and 2 threads (the bindings' random
 * sequences met a failing update on an empty scene). */
static void empty_scene_updates(void)
{
    int threads;
    for (threads = 1; threads <= 2; threads++) {
        locd_engine *e = new_engine((uint32_t)threads, NULL);
        locd_scene *s = NULL;
        model m;
        double b[6 * 3] = {0, 0, 0, 1, 1, 1, 0.5, 0.5, 0.5, 2, 2, 2, 5, 5, 5, 6, 6, 6};
        locd_id ids[3];
        size_t got, k;
        memset(&m, 0, sizeof m);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
        check_update(s, &m); /* nothing ever added */
        check_update(s, &m);
        add_boxes(s, &m, b, 3, 0, ids);
        check_update(s, &m);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, ids, 3));
        for (k = 0; k < 3; k++)
            m_remove(&m, ids[k]);
        check_update(s, &m); /* every pair lost */
        TEST_ASSERT_EQUAL_UINT64(0, locd_scene_count(s));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_query_box_f64(s, b, ~(uint64_t)0, ids, 3, &got));
        TEST_ASSERT_EQUAL_UINT64(0, got);
        check_update(s, &m); /* empty again, after removals */
        add_boxes(s, &m, b, 3, 1, ids); /* static this time: no pair */
        check_update(s, &m);
        add_boxes(s, &m, b, 2, 0, ids);
        check_update(s, &m);
        locd_scene_destroy(s);
        locd_engine_destroy(e);
        free(m.o), free(m.pairs);
    }
}

static void *query_thread(void *arg)
{
    query_job *j = arg;
    locd_id ids[512];
    double t[512];
    size_t n, i;
    int k;
    uint64_t h = 1469598103934665603ull;
    for (k = 0; k < 300; k++) {
        double q[6], o[3], d[3];
        int a;
        for (a = 0; a < 3; a++) {
            q[a] = (k * 7 % 50) + a, q[a + 3] = q[a] + 5.0;
            o[a] = q[a], d[a] = (a == k % 3) ? 10.0 : 0.5;
        }
        if (locd_scene_query_box_f64(j->s, q, ~(uint64_t)0, ids, 512, &n) != LOCD_OK)
            j->failed = 1;
        for (i = 0; i < n && !j->failed; i++)
            h = (h ^ ids[i]) * 1099511628211ull;
        if (locd_scene_raycast_f64(j->s, o, d, 3.0, ~(uint64_t)0, ids, t, 512, &n) != LOCD_OK)
            j->failed = 1;
        for (i = 0; i < n && !j->failed; i++)
            h = (h ^ ids[i]) * 1099511628211ull;
    }
    j->hash = h;
    return NULL;
}

static void queries_from_two_threads(void)
{
    locd_engine *e = new_engine(2, NULL);
    locd_scene *s = NULL;
    world w;
    double b[6 * 2000];
    locd_id ids[2000];
    query_job j0, j1, j2;
    pthread_t t1, t2;
    int i;
    memset(&w, 0, sizeof w);
    ts_seed(&w.r, 11);
    w.extent = 60.0, w.size = 2.0;
    for (i = 0; i < 2000; i++)
        random_box(&w, b + 6 * i);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, 1500, NULL, ids));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS));
    /* some changed since the update: the queries also try those one by one */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b + 6 * 1500, 500, NULL, ids + 1500));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, ids, b + 6 * 1000, 100));
    memset(&j0, 0, sizeof j0);
    j0.s = s;
    j1 = j0, j2 = j0;
    query_thread(&j0);
    TEST_ASSERT_EQUAL_INT(0, pthread_create(&t1, NULL, query_thread, &j1));
    TEST_ASSERT_EQUAL_INT(0, pthread_create(&t2, NULL, query_thread, &j2));
    pthread_join(t1, NULL);
    pthread_join(t2, NULL);
    TEST_ASSERT_FALSE(j0.failed || j1.failed || j2.failed);
    TEST_ASSERT_EQUAL_UINT64(j0.hash, j1.hash);
    TEST_ASSERT_EQUAL_UINT64(j0.hash, j2.hash);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
}

static const lt_test tests[] = {
    LT_TEST(empty_scene_updates),
    LT_TEST(queries_from_two_threads),
    LT_TEST(f32_entry_points_match_f64),
    LT_TEST(hard_cases),
    LT_TEST(a_box_over_everything),
    LT_TEST(float_copies_follow_the_boxes),
    LT_TEST(dense_and_sparse_dirty_lists),
    LT_TEST(large_scene_threads_and_fresh),
    LT_TEST(large_moves_on_the_pool),
    LT_TEST(whole_scene_moves_in_slot_order),
    LT_TEST(kept_entry_list_follows_whole_scene_moves),
    LT_TEST(kept_entry_list_pair_counts_jump),
    LT_TEST(whole_scene_move_encodes_for_the_update),
    LT_TEST(kept_entry_list_allocation_failures),
    LT_TEST(near_list_follows_whole_scene_moves),
    LT_TEST(near_list_allocation_failures),
    LT_TEST(from_scratch_events_at_the_ends),
    LT_TEST(from_scratch_follows_adds_removes_and_filters),
    LT_TEST(bad_batches_change_nothing),
    LT_TEST(levels_2_and_3_are_unsupported),
    LT_TEST(allocation_failures_change_nothing),
    LT_TEST(doubles_come_in_late),
    LT_TEST(random_sequences),
    LT_TEST(bigger_scene_two_threads),
    LT_TEST(whole_scene_moves_then_a_few),
    LT_TEST(thread_counts_give_identical_lists),
    LT_TEST(partner_lists_come_and_go),
};

int main(void)
{
    return LT_RUN(tests);
}
