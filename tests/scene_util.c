/* The scene suites' shared helpers (scene_util.h). */
#include "scene_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

void su_model_add(su_model *m, locd_id id, const double *box, uint64_t cat, uint64_t mask, uint64_t group,
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

su_obj *su_model_find(su_model *m, locd_id id)
{
    size_t k;
    for (k = 0; k < m->n; k++)
        if (m->o[k].id == id)
            return &m->o[k];
    return NULL;
}

void su_model_remove(su_model *m, locd_id id)
{
    su_obj *o = su_model_find(m, id);
    TEST_ASSERT_NOT_NULL(o);
    *o = m->o[--m->n];
}

static int overlap(const double *a, const double *b)
{
    return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

static int may_pair(const su_obj *a, const su_obj *b)
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

static int cmp_min_x(const void *pa, const void *pb)
{
    const su_obj *a = *(const su_obj *const *)pa, *b = *(const su_obj *const *)pb;
    return a->box[0] < b->box[0] ? -1 : a->box[0] > b->box[0];
}

/* Every pair of the model, sorted: the objects in order of min x, each
 * tested against those that start at or before its max x (a later one
 * starts past it on x and so cannot meet it; the closed test then decides).
 * All pairs' worth of tests made the sanitizer runs of the 16,000-object
 * scenes take minutes. */
static locd_id *m_pairs(const su_model *m, size_t *count)
{
    size_t i, j, w = 0, cap = 64;
    locd_id *r = malloc(cap * 2 * sizeof *r);
    const su_obj **by_x = malloc((m->n + 1) * sizeof *by_x);
    for (i = 0; i < m->n; i++)
        by_x[i] = &m->o[i];
    qsort(by_x, m->n, sizeof *by_x, cmp_min_x);
    for (i = 0; i < m->n; i++)
        for (j = i + 1; j < m->n && by_x[j]->box[0] <= by_x[i]->box[3]; j++)
            if (may_pair(by_x[i], by_x[j])) {
                const locd_id a = by_x[i]->id, b = by_x[j]->id;
                if (w == cap)
                    cap *= 2, r = realloc(r, cap * 2 * sizeof *r);
                r[2 * w] = a < b ? a : b;
                r[2 * w + 1] = a < b ? b : a;
                w++;
            }
    free(by_x);
    qsort(r, w, 2 * sizeof *r, cmp_row);
    *count = w;
    return r;
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

/* The same, into a malloc'd array; *count gets how many. */
static locd_id *minus(const locd_id *a, size_t na, const locd_id *b, size_t nb, size_t *count)
{
    locd_id *r = malloc((na ? na : 1) * 2 * sizeof *r);
    *count = rows_minus(a, na, b, nb, r);
    return r;
}

void su_same_rows(const char *what, const locd_id *want, size_t nwant, const locd_id *got, size_t ngot)
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

unsigned su_updates, su_incremental;

/* LOCD_TEST_HEAVY=0 (the sanitizer runs) shortens the sequences. */
int su_steps(int n)
{
    const char *v = getenv("LOCD_TEST_HEAVY");
    return v && v[0] == '0' ? (n + 9) / 10 : n;
}

/* Checks the lists of the update just made (pairs, created and lost)
 * against the model, and moves the model's previous set on. */
void su_check_lists(locd_scene *s, su_model *m)
{
    const locd_id *p;
    size_t np, nw, nc, nl;
    locd_id *want = m_pairs(m, &nw), *cr, *lo;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s, &p, &np));
    su_same_rows("pairs", want, nw, p, np);
    cr = minus(want, nw, m->pairs, m->npairs, &nc);
    lo = minus(m->pairs, m->npairs, want, nw, &nl);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_created(s, &p, &np));
    su_same_rows("created", cr, nc, p, np);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_lost(s, &p, &np));
    su_same_rows("lost", lo, nl, p, np);
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
        su_updates++;
        su_incremental += st.rebuilt == 0;
    }
}

/* Updates the scene and checks pairs, created and lost against the model. */
void su_check_update(locd_scene *s, su_model *m)
{
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS));
    su_check_lists(s, m);
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
void su_check_query(const locd_scene *s, const su_model *m, int kind, const double *q, uint64_t mask)
{
    hit *want = malloc((m->n + 1) * sizeof *want);
    locd_id *ids = malloc((m->n + 1) * sizeof *ids);
    double *ts = malloc((m->n + 1) * sizeof *ts);
    size_t k, w = 0, count = 99;
    for (k = 0; k < m->n; k++) {
        const su_obj *o = &m->o[k];
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
float su_to_float(double x)
{
    volatile float t = (float)x;
    return t;
}

/* ---- random worlds ---- */

/* A world of random boxes: coordinates in [0, extent), edges about size. */
su_world su_world_make(uint64_t seed, double extent, double size, int shape)
{
    su_world w;
    memset(&w, 0, sizeof w);
    ts_seed(&w.r, seed);
    w.extent = extent, w.size = size, w.shape = shape;
    return w;
}

void su_random_box(su_world *w, double *b)
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
            b[a] = su_to_float(b[a]); /* representable in float too */
}

uint64_t su_random_bits(su_world *w)
{
    /* few bits, so that filters bite often */
    static const uint64_t v[] = {1, 2, 3, 4, 7, ~(uint64_t)0};
    return v[ts_next(&w->r) % 6];
}

locd_engine *su_new_engine(uint32_t threads, const locd_allocator *alloc)
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
const locd_scene_config su_kept_cfg = {sizeof(locd_scene_config), LOCD_SCENE_NO_NEAR_LIST, 0};

void su_random_query(su_world *w, const locd_scene *s, const su_model *m)
{
    double q[7];
    int kind = (int)(ts_next(&w->r) % 3);
    uint64_t mask = su_random_bits(w);
    su_random_box(w, q);
    if (kind == 0 && (ts_next(&w->r) & 3) == 0) { /* a large region */
        int a;
        for (a = 0; a < 3; a++)
            q[a + 3] = q[a] + w->extent * 0.5;
    }
    if (kind == 2) {
        int a;
        if ((ts_next(&w->r) & 7) == 0 && m->n) { /* start inside an object */
            const su_obj *o = &m->o[ts_next(&w->r) % m->n];
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
    su_check_query(s, m, kind, q, mask);
}

/* The pairs of a fresh scene of the model's objects (its first update is a
 * rebuild), in the model's ids, sorted. */
locd_id *su_fresh_pairs(locd_engine *e, const su_model *m, size_t *count)
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

/* ---- scenes and the model side by side ---- */

/* Adds n boxes (dynamic, or static) to scene and model. */
void su_add_boxes(locd_scene *s, su_model *m, const double *b, size_t n, int stat, locd_id *ids)
{
    locd_scene_add_options o;
    size_t k;
    locd_scene_add_options_init(&o);
    o.flags = stat ? LOCD_OBJECT_STATIC : 0;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, n, &o, ids));
    for (k = 0; k < n; k++)
        su_model_add(m, ids[k], b + 6 * k, 1, ~(uint64_t)0, 0, 0, stat);
}

void su_move_box(locd_scene *s, su_model *m, locd_id id, const double *b)
{
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, &id, b, 1));
    memcpy(su_model_find(m, id)->box, b, 6 * sizeof *b);
}

/* Moves every object of the model to its box in the model (so that the
 * update finds its pairs from scratch), updates, checks, and checks that
 * it was from scratch. */
void su_update_all_from_scratch(locd_scene *s, su_model *m)
{
    size_t k;
    locd_scene_stats st;
    for (k = 0; k < m->n; k++)
        su_move_box(s, m, m->o[k].id, m->o[k].box);
    su_check_update(s, m);
    locd_scene_stats_init(&st);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s, &st));
    TEST_ASSERT_EQUAL_UINT32(1, st.rebuilt);
}

/* ---- the engine's own find as the reference ---- */

/* The pairs of boxes f[0, n) as rows of ids[] (ascending with the index),
 * found by the engine's own find: a reference that shares no code with
 * the scene's kept entry list or near-pair list. With `grouped` > 0, less
 * the pairs of two objects whose index is a multiple of it (one group);
 * less the pairs of two objects from index first_static on (static). */
locd_id *su_engine_rows_filtered(locd_engine *e, const float *f, const locd_id *ids, size_t n, uint32_t grouped,
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

locd_id *su_engine_rows(locd_engine *e, const float *f, const locd_id *ids, size_t n, uint32_t grouped,
                            size_t *count)
{
    return su_engine_rows_filtered(e, f, ids, n, grouped, n, count);
}

/* The scene's pairs, created and lost of its last update against the
 * reference rows now and before it. */
void su_check_lists_against(locd_scene *s, const locd_id *now, size_t nnow, const locd_id *before,
                                size_t nbefore)
{
    const locd_id *p;
    size_t np, nw;
    locd_id *want = malloc((nnow + nbefore + 1) * 2 * sizeof *want);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s, &p, &np));
    su_same_rows("pairs against the engine's find", now, nnow, p, np);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_created(s, &p, &np));
    nw = rows_minus(now, nnow, before, nbefore, want);
    su_same_rows("created against the engine's finds", want, nw, p, np);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_lost(s, &p, &np));
    nw = rows_minus(before, nbefore, now, nnow, want);
    su_same_rows("lost against the engine's finds", want, nw, p, np);
    free(want);
}

/* An update, then its lists against the reference rows now and before. */
void su_check_against(locd_scene *s, const locd_id *now, size_t nnow, const locd_id *before, size_t nbefore)
{
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS));
    su_check_lists_against(s, now, nnow, before, nbefore);
}

/* Boxes of edge `edge` at random corners in the unit cube, or (jitter)
 * each one's corner stepped by up to `jitter` on each axis. */
void su_cube_boxes(ts_rng *r, float *f, size_t n, double edge, double jitter)
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
