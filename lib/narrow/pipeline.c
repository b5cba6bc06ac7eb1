/* The filter pipeline: broad phase (the locd engine on the shapes' world
 * boxes, swept boxes for moving objects when swept tests are on), then only
 * the stages the caller asked for: shape test, time-of-impact test, contact
 * data. A stage not asked for is not entered (its statistics stay 0). */
#include "core/core.h"
#include "narrow/narrow.h"

#include <math.h>
#include <stdlib.h>

/* Copies a caller's (possibly older, smaller) options over the defaults. */
static locd_status read_options(const locd_pipeline_options *in, locd_pipeline_options *o)
{
    size_t k;
    locd_status st;
    locd_pipeline_options_init(o);
    if (!in)
        return LOCD_OK;
    if ((st = lc_struct_in(o, sizeof *o, in, LOCD_PIPELINE_OPTIONS_MIN_SIZE, "options")) != LOCD_OK)
        return st;
    if (o->stages & ~(LOCD_STAGE_SHAPE | LOCD_STAGE_CONTACT))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "unknown stage bits 0x%x", o->stages);
    if (o->swept < LOCD_SWEPT_OFF || o->swept > LOCD_SWEPT_AUTO)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "unknown swept mode %d", (int)o->swept);
    if (o->contact_method != LOCD_CONTACT_EPA && o->contact_method != LOCD_CONTACT_MPR)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "unknown contact method %d", (int)o->contact_method);
    if (!isfinite(o->dt) || o->dt < 0.0 || !isfinite(o->swept_threshold) || o->swept_threshold < 0.0)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "dt %g and swept_threshold %g must be finite and >= 0", o->dt,
                        o->swept_threshold);
    for (k = 0; k < sizeof o->route; k++)
        if (o->route[k] > LOCD_ROUTE_FCL)
            return lc_error(LOCD_ERR_INVALID_ARGUMENT, "route entry %zu is %u", k, o->route[k]);
    return LOCD_OK;
}

static locd_status reserve_scratch(locd_world *w, size_t pairs)
{
    /* Scratch is refilled by every call: new blocks, nothing copied. */
    if (w->scratch_n < w->n) {
        size_t n = w->n;
        lc_world_free_scratch(w);
        w->all_dirty = 1; /* new blocks: every box is computed again */
        w->R = lc_alloc(&w->alloc, n * 12 * sizeof(double));
        w->boxes = lc_alloc(&w->alloc, n * 6 * sizeof(double));
        w->fast = lc_alloc(&w->alloc, n);
        w->scratch_n = n;
        if (!w->R || !w->boxes || !w->fast) {
            lc_world_free_scratch(w);
            return lc_error(LOCD_ERR_NO_MEMORY, "pipeline scratch");
        }
    }
    if (w->work_cap < pairs) {
        size_t bytes;
        uint32_t *work;
        if (!lc_mul_size(pairs, sizeof(uint32_t), &bytes) || !(work = lc_alloc(&w->alloc, bytes)))
            return lc_error(LOCD_ERR_NO_MEMORY, "pipeline scratch");
        lc_free(&w->alloc, w->work, w->work_cap * sizeof(uint32_t));
        w->work = work;
        w->work_cap = pairs;
    }
    return LOCD_OK;
}

/* Object i placed at time s * dt along its velocity (translation only). */
static void placed_at(const locd_world *w, size_t i, double s, double dt, lc_placed *p)
{
    const double *v = w->vel + 6 * i;
    lc_place(w->shapes[i], w->R + 12 * i, w->R + 12 * i + 9, p);
    p->t[0] += s * dt * v[0];
    p->t[1] += s * dt * v[1];
    p->t[2] += s * dt * v[2];
}

static int moving(const double *v)
{
    return v[0] != 0.0 || v[1] != 0.0 || v[2] != 0.0 || v[3] != 0.0 || v[4] != 0.0 || v[5] != 0.0;
}

/* World boxes; with swept tests on, a moving object's box covers its whole
 * motion in the step (union of the start and end boxes for a translation; of
 * the bounding spheres' boxes when it also turns). Only the objects whose
 * pose or velocity changed get theirs computed again (all of them when the
 * options that shape the boxes changed); those are marked pending for the
 * broad phase, which moves them in its scene if their box changed. */
static void world_boxes(locd_world *w, const locd_pipeline_options *o, uint32_t *nswept)
{
    uint8_t *dirty = w->dirty.data, *pending = w->broad.pending.data;
    size_t i;
    int a, all;
    *nswept = 0;
    all = w->all_dirty || o->swept != w->box_swept || o->dt != w->box_dt || o->swept_threshold != w->box_threshold;
    w->all_dirty = 0;
    w->box_swept = o->swept;
    w->box_dt = o->dt;
    w->box_threshold = o->swept_threshold;
    for (i = 0; i < w->n; i++) {
        const double *v = w->vel + 6 * i;
        double *box = w->boxes + 6 * i;
        lc_placed p;
        if (!w->shapes[i])
            continue; /* removed */
        if (!all && !dirty[i]) {
            *nswept += w->fast[i];
            continue;
        }
        dirty[i] = 0;
        pending[i] = 1;
        lc_pose_to_rt(w->poses + 7 * i, w->R + 12 * i, w->R + 12 * i + 9);
        lc_place(w->shapes[i], w->R + 12 * i, w->R + 12 * i + 9, &p);
        lc_placed_box(&p, box);
        w->fast[i] = 0;
        if (o->swept == LOCD_SWEPT_OFF || o->dt <= 0.0 || !moving(v))
            continue;
        {
            double d[3] = {v[0] * o->dt, v[1] * o->dt, v[2] * o->dt};
            double motion = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            if (o->swept == LOCD_SWEPT_ON || motion > o->swept_threshold * w->shapes[i]->extent) {
                w->fast[i] = 1;
                (*nswept)++;
            }
            if (v[3] == 0.0 && v[4] == 0.0 && v[5] == 0.0) {
                for (a = 0; a < 3; a++) {
                    box[a] = fmin(box[a], box[a] + d[a]);
                    box[3 + a] = fmax(box[3 + a], box[3 + a] + d[a]);
                }
            } else {
                double r = w->shapes[i]->bound_radius;
                for (a = 0; a < 3; a++) {
                    box[a] = fmin(box[a], fmin(p.t[a], p.t[a] + d[a]) - r);
                    box[3 + a] = fmax(box[3 + a], fmax(p.t[a], p.t[a] + d[a]) + r);
                }
            }
        }
    }
}

static locd_status append(locd_contacts *out, uint32_t i, uint32_t j, double toi)
{
    locd_status st = lc_contacts_reserve(out, out->count + 1);
    if (st != LOCD_OK)
        return st;
    out->pairs[2 * out->count] = i;
    out->pairs[2 * out->count + 1] = j;
    out->toi[out->count] = toi;
    out->count++;
    return LOCD_OK;
}

static int32_t route_of(const locd_world *w, const locd_pipeline_options *o, uint32_t i, uint32_t j)
{
    return o->route[w->shapes[i]->kind * LOCD_SHAPE_KINDS + w->shapes[j]->kind];
}

/* Discrete pairs: the exact shape test at the start of the step. */
static locd_status stage_shape(locd_world *w, const locd_pipeline_options *o, const uint32_t *pairs, size_t m,
                               locd_contacts *out, locd_pipeline_stats *s)
{
    size_t k;
    double t0 = lc_now_ms();
    uint64_t counts[3] = {0, 0, 0};
    s->shape.calls++;
    s->shape.pairs_in += m;
    for (k = 0; k < m; k++) {
        uint32_t i = pairs[2 * k], j = pairs[2 * k + 1];
        lc_placed a, b;
        int r;
        placed_at(w, i, 0.0, 0.0, &a);
        placed_at(w, j, 0.0, 0.0, &b);
        r = lc_pair_test(&a, &b, route_of(w, o, i, j), 0, o->contact_method, NULL, counts);
        if (r < 0)
            return r;
        if (r) {
            locd_status st = append(out, i, j, 0.0);
            if (st != LOCD_OK)
                return st;
            s->shape.pairs_out++;
        }
    }
    s->shape.tests += counts[0] + counts[1] + counts[2];
    s->tests_closed += counts[0];
    s->tests_ccd += counts[1];
    s->tests_fcl += counts[2];
    s->shape.ms += lc_now_ms() - t0;
    return LOCD_OK;
}

/* Pairs with a swept object: first time of impact within the step. */
static locd_status stage_swept(locd_world *w, const locd_pipeline_options *o, const uint32_t *pairs, size_t m,
                               locd_contacts *out, locd_pipeline_stats *s)
{
    size_t k;
    double t0 = lc_now_ms();
    uint64_t counts[3] = {0, 0, 0};
    s->swept.calls++;
    s->swept.pairs_in += m;
    for (k = 0; k < m; k++) {
        uint32_t i = pairs[2 * k], j = pairs[2 * k + 1];
        const double *vi = w->vel + 6 * i, *vj = w->vel + 6 * j;
        double d[3] = {(vj[0] - vi[0]) * o->dt, (vj[1] - vi[1]) * o->dt, (vj[2] - vi[2]) * o->dt}, toi = 0.0;
        lc_placed a, b;
        int r;
        placed_at(w, i, 0.0, 0.0, &a);
        placed_at(w, j, 0.0, 0.0, &b);
        r = lc_pair_sweep(&a, &b, d, route_of(w, o, i, j), &toi, counts);
        if (r < 0)
            return r;
        if (r) {
            locd_status st = append(out, i, j, toi);
            if (st != LOCD_OK)
                return st;
            s->swept.pairs_out++;
        }
    }
    s->swept.tests += counts[0] + counts[1] + counts[2];
    s->tests_closed += counts[0];
    s->tests_ccd += counts[1];
    s->tests_fcl += counts[2];
    s->swept.ms += lc_now_ms() - t0;
    return LOCD_OK;
}

/* Contact data at the time of impact; pairs that do not touch there (box
 * route, or shape test skipped) are dropped. A swept pair whose contact test
 * misses by the bisection's margin keeps a contact along its motion. */
static locd_status stage_contact(locd_world *w, const locd_pipeline_options *o, locd_contacts *out,
                                 locd_pipeline_stats *s)
{
    size_t k, kept = 0;
    double t0 = lc_now_ms();
    uint64_t counts[3] = {0, 0, 0};
    s->contact.calls++;
    s->contact.pairs_in += out->count;
    out->has_contact = 1;
    for (k = 0; k < out->count; k++) {
        uint32_t i = out->pairs[2 * k], j = out->pairs[2 * k + 1];
        double toi = out->toi[k];
        int32_t route = route_of(w, o, i, j);
        int swept = w->fast[i] || w->fast[j];
        lc_placed a, b;
        lc_contact c;
        int r;
        if (lc_route_resolve(route, w->shapes[i]->kind, w->shapes[j]->kind) == LOCD_ROUTE_BOX)
            route = LOCD_ROUTE_AUTO;
        placed_at(w, i, swept ? toi : 0.0, o->dt, &a);
        placed_at(w, j, swept ? toi : 0.0, o->dt, &b);
        r = lc_pair_test(&a, &b, route, 1, o->contact_method, &c, counts);
        if (r < 0)
            return r;
        if (!r && swept) {
            const double *vi = w->vel + 6 * i, *vj = w->vel + 6 * j;
            double d[3] = {vi[0] - vj[0], vi[1] - vj[1], vi[2] - vj[2]};
            double n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            c.depth = 0.0;
            for (r = 0; r < 3; r++) {
                c.normal[r] = n > 0.0 ? d[r] / n : (r == 2);
                c.point[r] = 0.5 * (a.t[r] + b.t[r]);
            }
            r = 1;
        }
        if (!r)
            continue;
        out->pairs[2 * kept] = i;
        out->pairs[2 * kept + 1] = j;
        out->toi[kept] = toi;
        out->depth[kept] = c.depth;
        memcpy(out->normal + 3 * kept, c.normal, sizeof c.normal);
        memcpy(out->point + 3 * kept, c.point, sizeof c.point);
        kept++;
    }
    out->count = kept;
    s->contact.pairs_out += kept;
    s->contact.tests += counts[0] + counts[1] + counts[2];
    s->tests_closed += counts[0];
    s->tests_ccd += counts[1];
    s->tests_fcl += counts[2];
    s->contact.ms += lc_now_ms() - t0;
    return LOCD_OK;
}

/* Broad phase, then the discrete and the swept pairs apart (discrete hits
 * come first in the result, each part in broad-phase order). */
static locd_status run(locd_world *w, const locd_pipeline_options *o, locd_contacts *out, locd_pipeline_stats *s)
{
    uint64_t candidates;
    const uint32_t *bp;
    size_t m, k, nd = 0, ns = 0;
    uint32_t *disc, *swept;
    double t0 = lc_now_ms();
    locd_status st;

    s->objects = (uint32_t)w->live;
    st = reserve_scratch(w, 0);
    if (st != LOCD_OK)
        return st;
    world_boxes(w, o, &s->swept_objects);
    /* Only the objects whose box changed cost anything here (world_broad.c). */
    if ((st = lc_world_broad_find(w, o->find_flags, &candidates)) != LOCD_OK)
        return st;
    m = locd_pairs_count(w->pairs);
    s->broad.tests = candidates;
    s->broad.calls = 1;
    s->broad.pairs_in = w->live > 1 ? (uint64_t)w->live * (uint64_t)(w->live - 1) / 2 : 0;
    s->broad.pairs_out = m;
    s->broad.ms = lc_now_ms() - t0;

    if ((st = reserve_scratch(w, 2 * m)) != LOCD_OK || (st = lc_contacts_reserve(out, m)) != LOCD_OK)
        return st;
    bp = locd_pairs_data(w->pairs);
    /* Discrete pairs fill the scratch from the front, swept ones from the back. */
    disc = w->work;
    for (k = 0; k < m; k++) {
        uint32_t i = bp[2 * k], j = bp[2 * k + 1];
        uint32_t *dst = (w->fast[i] || w->fast[j]) ? w->work + 2 * (m - 1 - ns++) : disc + 2 * nd++;
        dst[0] = i < j ? i : j;
        dst[1] = i < j ? j : i;
    }
    swept = w->work + 2 * (m - ns);
    /* The back part was filled in reverse: restore broad-phase order. */
    for (k = 0; k < ns / 2; k++) {
        uint32_t *p = swept + 2 * k, *q = swept + 2 * (ns - 1 - k), t;
        t = p[0], p[0] = q[0], q[0] = t;
        t = p[1], p[1] = q[1], q[1] = t;
    }
    if (o->stages & LOCD_STAGE_SHAPE) {
        if ((st = stage_shape(w, o, disc, nd, out, s)) != LOCD_OK)
            return st;
    } else {
        for (k = 0; k < nd; k++)
            if ((st = append(out, disc[2 * k], disc[2 * k + 1], 0.0)) != LOCD_OK)
                return st;
    }
    if (o->swept != LOCD_SWEPT_OFF && o->dt > 0.0 && (st = stage_swept(w, o, swept, ns, out, s)) != LOCD_OK)
        return st;
    if (o->stages & LOCD_STAGE_CONTACT)
        if ((st = stage_contact(w, o, out, s)) != LOCD_OK)
            return st;
    return LOCD_OK;
}

locd_status locd_world_collide(locd_world *w, const locd_pipeline_options *options, locd_contacts *out,
                               locd_pipeline_stats *stats)
{
    locd_pipeline_options o;
    locd_pipeline_stats s;
    double t0 = lc_now_ms();
    locd_status st;
    if ((st = lc_world_check(w)) != LOCD_OK || (st = lc_contacts_check(out)) != LOCD_OK)
        return st;
    if (stats && (st = lc_struct_check(stats, sizeof s, LOCD_PIPELINE_STATS_MIN_SIZE, "stats")) != LOCD_OK)
        return st;
    if ((st = read_options(options, &o)) != LOCD_OK)
        return st;
    out->count = 0;
    out->has_contact = 0;
    locd_pipeline_stats_init(&s);
    lc_world_events_clear(w);
    st = run(w, &o, out, &s);
    if (st == LOCD_OK)
        st = lc_world_events_update(w, out);
    if (st != LOCD_OK) {
        out->count = 0;
        out->has_contact = 0;
        return st;
    }
    s.ms_total = lc_now_ms() - t0;
    if (stats)
        lc_struct_out(stats, &s);
    lc_clear_error();
    return LOCD_OK;
}
