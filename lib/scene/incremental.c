/* The incremental path (docs/scene.md, "One update"): the moved objects'
 * cells are computed again (encode_moved.c); those whose cells changed
 * have their old entries deleted and their new ones added by one merge
 * pass per list; the moved objects' pairs are found in the repaired lists
 * or their partner lists (moved_pairs.c); the pairs between unmoved
 * objects are carried over from the previous set. What it writes early
 * (cells, records, tombstones) is undone on failure. */
#include "scene/scene.h"
#include "scene/update.h"

/* The survey's totals over the parts. */
typedef struct survey_sum {
    size_t fresh, stay, srch, calm, ndel[2], nadd[2], nq;
    int outside;
} survey_sum;

static void sum_parts(const lc_encode_plan *p, survey_sum *m)
{
    uint32_t t;
    memset(m, 0, sizeof *m);
    for (t = 0; t < p->k; t++) {
        const lc_encode_part *pt = &p->part[t];
        m->fresh += pt->fresh, m->outside |= pt->outside;
        m->stay += pt->nstay, m->srch += pt->nsrch, m->calm += pt->calm;
        m->ndel[0] += pt->ndel[0], m->ndel[1] += pt->ndel[1];
        m->nadd[0] += pt->nadd[0], m->nadd[1] += pt->nadd[1];
        m->nq += pt->nq;
    }
}

/* What the survey found that makes the update choose again (nothing
 * written but scratch): a box outside the root cube or more new objects
 * than the numbering has room for; most moved objects out of their fat
 * boxes (the partner lists are dropped: a cache, dropping it changes no
 * result). Else the back-off's note of how calm the moved objects were. */
static lc_finding survey_finding(lc_update *u, const survey_sum *m)
{
    locd_scene *s = u->s;
    if (m->outside || s->entries.ndense + m->fresh > s->entries.cap)
        return LC_FOUND_OUTSIDE;
    if (s->partners.valid && lc_path_partners_go(m->srch, m->stay, s->slots.live)) {
        lc_partners_drop(s);
        lc_backoff_partners_dropped(&s->backoff);
        return LC_FOUND_MOST_LEFT;
    }
    u->partners_after = lc_backoff_survey(&s->backoff, s->partners.valid, m->calm, m->stay + m->srch);
    return LC_FOUND_NOTHING;
}

/* Where the deltas go in u->buf: deleted (dynamic, static), added
 * (dynamic, static), then the query entries. */
typedef struct delta_at {
    size_t del[2], add[2], q, ndel[2], nadd[2], nq;
    size_t nundo, nstay, nsrch, ndense; /* what pass 2 will have written */
} delta_at;

/* The removed objects' old entries, first in the deleted parts, and their
 * records marked GONE (the undo clears it). */
static void removed_deletions(lc_update *u, const delta_at *at)
{
    locd_scene *s = u->s;
    const uint32_t *r = s->slots.removed.data;
    size_t k, w[2] = {0, 0};
    for (k = 0; k < s->slots.nremoved; k++)
        if (s->slots.flags[r[k]] & LC_SLOT_LISTED) {
            const int l = (s->slots.flags[r[k]] & LC_SLOT_STATIC) ? 1 : 0;
            const uint32_t d = s->entries.dense[r[k]];
            w[l] += lc_cells_entries(&s->entries.grid, &s->entries.cell[r[k]], d, u->buf + at->del[l] + w[l]);
            s->entries.rec[d].flags |= LC_REC_GONE;
        }
    u->undo.gone = 1;
}

/* The deltas' places: the removed objects' deletions, then each part's
 * rows where the serial loop would put them. */
static locd_status place_deltas(lc_update *u, lc_encode_plan *p, const survey_sum *m, delta_at *at)
{
    locd_scene *s = u->s;
    const uint32_t *r = s->slots.removed.data;
    size_t k, nrem[2] = {0, 0}, cur_del[2], cur_add[2], cur_q, undo = 0, dense = s->entries.ndense, stay = 0, srch = 0;
    uint32_t t;
    int l;
    for (k = 0; k < s->slots.nremoved; k++)
        if (s->slots.flags[r[k]] & LC_SLOT_LISTED)
            nrem[(s->slots.flags[r[k]] & LC_SLOT_STATIC) ? 1 : 0] += lc_cells_count(&s->entries.cell[r[k]]);
    for (l = 0; l < 2; l++)
        at->ndel[l] = m->ndel[l] + nrem[l], at->nadd[l] = m->nadd[l];
    at->nq = m->nq;
    at->del[0] = 0, at->del[1] = at->ndel[0];
    at->add[0] = at->ndel[0] + at->ndel[1], at->add[1] = at->add[0] + at->nadd[0];
    at->q = at->add[1] + at->nadd[1];
    for (l = 0; l < 2; l++)
        cur_del[l] = at->del[l] + nrem[l], cur_add[l] = at->add[l];
    cur_q = at->q;
    for (t = 0; t < p->k; t++) {
        lc_encode_part *pt = &p->part[t];
        size_t c;
        for (l = 0; l < 2; l++) {
            c = pt->ndel[l], pt->ndel[l] = cur_del[l], cur_del[l] += c;
            c = pt->nadd[l], pt->nadd[l] = cur_add[l], cur_add[l] += c;
        }
        c = pt->nq, pt->nq = cur_q, cur_q += c;
        c = pt->live, pt->live = undo, undo += c;
        c = pt->fresh, pt->fresh = dense, dense += c;
        c = pt->nstay, pt->nstay = stay, stay += c;
        c = pt->nsrch, pt->nsrch = srch, srch += c;
    }
    at->nundo = undo, at->nstay = stay, at->nsrch = srch, at->ndense = dense;
    return lc_update_room(u, 0, at->q + at->nq + 1);
}

/* Pass 2, then the deltas sorted. */
static locd_status write_deltas(lc_update *u, lc_encode_plan *p, const delta_at *at)
{
    const locd_allocator *a = u->s->alloc;
    locd_status st;
    uint32_t t;
    int l;
    removed_deletions(u, at);
    lc_encode_run(p, 2);
    u->undo.n = at->nundo, u->nstay = at->nstay, u->nsrch = at->nsrch;
    u->s->entries.ndense = at->ndense;
    for (t = 0; t < p->k; t++)
        u->reencoded += p->part[t].reenc;
    for (l = 0; l < 2; l++)
        if ((st = lc_sort_u64_radix(a, u->buf + at->del[l], at->ndel[l])) != LOCD_OK ||
            (st = lc_sort_u64_radix(a, u->buf + at->add[l], at->nadd[l])) != LOCD_OK)
            return st;
    return lc_sort_u64_radix(a, u->buf + at->q, at->nq);
}

locd_status lc_incremental(lc_update *u, lc_finding *found)
{
    locd_scene *s = u->s;
    lc_entries *en = &s->entries;
    lc_encode_plan p;
    survey_sum m;
    delta_at at;
    lc_entry_list dyn, sta;
    lc_moved mv;
    locd_status st;
    double t0 = lc_now_ms(), t1;
    if ((st = lc_update_moved_room(u, s->slots.ndirty, 1)) != LOCD_OK)
        return st;
    u->undo.ndense_before = en->ndense;
    lc_encode_plan_init(&p, u);
    lc_encode_run(&p, 1);
    sum_parts(&p, &m);
    if ((*found = survey_finding(u, &m)) != LC_FOUND_NOTHING)
        return LOCD_OK;
    if ((st = place_deltas(u, &p, &m, &at)) != LOCD_OK || (st = write_deltas(u, &p, &at)) != LOCD_OK)
        return st;
    t1 = lc_now_ms();
    u->ms_encode = t1 - t0;
    t0 = t1;
    if ((st = lc_entry_edit_apply(s->alloc, &en->grid, &en->dyn, u->buf + at.del[0], at.ndel[0], u->buf + at.add[0],
                                  at.nadd[0], &u->edit[0])) != LOCD_OK ||
        (st = lc_entry_edit_apply(s->alloc, &en->grid, &en->sta, u->buf + at.del[1], at.ndel[1], u->buf + at.add[1],
                                  at.nadd[1], &u->edit[1])) != LOCD_OK)
        return st;
    /* The search sees the lists as they will be: a view of each. */
    lc_entry_edit_view(&en->dyn, &u->edit[0], &dyn);
    lc_entry_edit_view(&en->sta, &u->edit[1], &sta);
    u->ms_merge = lc_now_ms() - t0;
    mv.dyn = &dyn, mv.sta = &sta, mv.q = u->buf + at.q, mv.nq = at.nq, mv.stay = u->stay, mv.nstay = u->nstay;
    u->events = s->partners.valid;
    return (u->events ? lc_moved_events : lc_moved_pairs)(u, &mv);
}

void lc_incremental_undo(lc_update *u)
{
    locd_scene *s = u->s;
    lc_entries *en = &s->entries;
    lc_undo *un = &u->undo;
    size_t k;
    for (k = un->n; k-- > 0;) {
        const uint32_t slot = un->slot[k];
        const uint32_t di = (un->flags[k] & LC_SLOT_LISTED) ? un->dense[k] : en->dense[slot];
        en->rec[di] = un->rec[k];
        if (un->flags[k] & LC_UNDO_RECORD) /* the record was all that changed */
            continue;
        memcpy(en->qfat + LC_FAT_WORDS * (size_t)di, un->qfat + LC_FAT_WORDS * k, LC_FAT_WORDS * sizeof *en->qfat);
        en->cell[slot] = un->cells[k];
        en->dense[slot] = un->dense[k];
        s->slots.flags[slot] = un->flags[k];
    }
    if (un->n)
        en->ndense = un->ndense_before;
    un->n = 0;
    if (un->gone)
        for (k = 0; k < s->slots.nremoved; k++) {
            const uint32_t slot = ((const uint32_t *)s->slots.removed.data)[k];
            if (s->slots.flags[slot] & LC_SLOT_LISTED)
                en->rec[en->dense[slot]].flags &= ~(uint32_t)LC_REC_GONE;
        }
    un->gone = 0;
    lc_entry_edit_undo(&en->dyn, &u->edit[0]);
    lc_entry_edit_undo(&en->sta, &u->edit[1]);
}

/* The partner lists after the update: the removed objects and those that
 * searched leave their old partners' lists, then the searched ones are
 * linked to the fat partners they found. */
static void relink(lc_update *u)
{
    locd_scene *s = u->s;
    const uint32_t *r = s->slots.removed.data, *fp = u->found.fat.data, *ev = u->found.ev.data;
    size_t k;
    if (!s->partners.valid || !u->events)
        return;
    /* the partner-list pass's changes first: their places k hold until a
       list is unlinked below */
    for (k = 0; k < u->found.nev; k++)
        lc_partners_set_paired(s, ev[3 * k], ev[3 * k + 1], ev[3 * k + 2] & LC_INDEX_BITS,
                               (ev[3 * k + 2] & LC_PAIRED) != 0);
    for (k = 0; k < s->slots.nremoved; k++)
        if (s->slots.flags[r[k]] & LC_SLOT_LISTED)
            lc_partners_unlink(s, s->entries.dense[r[k]]);
    for (k = 0; k < u->nsrch; k++)
        lc_partners_unlink(s, u->srch[k]);
    for (k = 0; k < u->found.nfat && s->partners.valid; k++)
        lc_partners_link(s, fp[2 * k], fp[2 * k + 1] & LC_INDEX_BITS, (fp[2 * k + 1] & LC_PAIRED) != 0);
}

void lc_incremental_commit(lc_update *u)
{
    locd_scene *s = u->s;
    lc_entry_edit_commit(s->alloc, &s->entries.dyn, &u->edit[0]);
    lc_entry_edit_commit(s->alloc, &s->entries.sta, &u->edit[1]);
    u->undo.n = 0;
    u->undo.gone = 0;
    relink(u);
    if (u->partners_after && !s->partners.valid) {
        lc_partners_build(s); /* from the boxes now, as the set is; on failure the scene goes on without */
        lc_backoff_partners_built(&s->backoff);
    }
}
