/* The moved objects' encode, step 1 of an incremental update: the dirty
 * list split over the pool when it is long. Pass 1 (the survey) computes
 * each object's new cells and packed box and counts its entries (queries,
 * deleted, added); pass 2 writes them at offsets the counts give, with the
 * undo rows. Every part writes where the serial loop would have, and takes
 * the next dense indices in dirty-list order, so the lists and the undo are
 * the same for every thread count. */
#include "scene/scene.h"
#include "scene/update.h"

/* From this many dirty objects on, the passes run on the pool. */
#define LC_ENCODE_SPLIT 8192

/* Starts loading what pass 1 reads of the dirty objects ahead: their
 * flags, boxes and dense indices, then (when the dense index has come)
 * their packed fat boxes. The dirty slots are scattered: a miss each,
 * overlapped. */
LC_INLINE void survey_prefetch(const locd_scene *s, const uint32_t *d, size_t k, size_t e)
{
    if (k + 2 * LC_AHEAD < e) {
        const uint32_t ahead = d[k + 2 * LC_AHEAD];
        __builtin_prefetch(s->slots.flags + ahead);
        lc_slot_prefetch_box(&s->slots, ahead, 0);
        __builtin_prefetch(s->entries.dense + ahead);
    }
    if (k + LC_AHEAD < e) {
        const uint32_t ahead = d[k + LC_AHEAD];
        if (s->slots.flags[ahead] & LC_SLOT_LISTED)
            __builtin_prefetch(s->entries.qfat + LC_FAT_WORDS * (size_t)s->entries.dense[ahead]);
    }
}

/* 1 when the object in `slot` (flags f, new packed box q) is still inside
 * its fat box with the filter it had: its cells, its entries and its
 * partners stay; only its packed box is new. */
LC_INLINE int stays(const locd_scene *s, uint32_t slot, uint8_t f, const uint64_t *q)
{
    return (f & (LC_SLOT_LISTED | LC_SLOT_REFILTER)) == LC_SLOT_LISTED &&
           lc_qbox_inside(q + 2, s->entries.qfat + LC_FAT_WORDS * (size_t)s->entries.dense[slot]);
}

/* Pass 1. The counts go through a local copy of the part, stored back at
 * the end: the parts of two threads lie side by side (one cache line may
 * hold the end of one and the start of the next), and the loop stores its
 * counts at every step (it cannot keep them in registers past its other
 * stores). */
static void survey_part(lc_update *u, lc_encode_part *shared)
{
    locd_scene *s = u->s;
    const locd_grid *g = &s->entries.grid;
    const uint32_t *d = s->slots.dirty.data;
    lc_encode_part part = *shared, *pt = &part;
    size_t k;
    for (k = pt->b; k < pt->e; k++) {
        const uint32_t slot = d[k];
        const uint8_t f = s->slots.flags[slot];
        const int l = (f & LC_SLOT_STATIC) ? 1 : 0;
        uint64_t *q = u->new_q + LC_QPAIR * k;
        double box[6];
        const double *b;
        lc_qcorners qc;
        lc_cells c;
        uint32_t cnt, ext;
        survey_prefetch(s, d, k, pt->e);
        if (!(f & LC_SLOT_LIVE))
            continue;
        pt->live++;
        pt->fresh += !(f & LC_SLOT_LISTED);
        b = lc_slot_box(&s->slots, slot, box);
        pt->outside |= !lc_grid_holds(g, b);
        ext = lc_cells_box(g, b, &qc, q);
        if (stays(s, slot, f, q)) {
            pt->calm++;
            if (s->partners.valid) { /* its fat box and cells stay: pass 2 reads only pad[0] */
                memset(&c, 0, sizeof c);
                c.pad[0] = 1;
                u->new_cells[k] = c;
                pt->nstay++;
                continue;
            }
        }
        lc_cells_fat(g, &qc, ext, &c, q);
        pt->nsrch++;
        u->new_cells[k] = c;
        cnt = lc_cells_count(&c);
        pt->nq += cnt;
        if ((f & LC_SLOT_LISTED) && lc_cells_same(&c, &s->entries.cell[slot]))
            continue;
        if (f & LC_SLOT_LISTED)
            pt->ndel[l] += lc_cells_count(&s->entries.cell[slot]);
        pt->nadd[l] += cnt;
    }
    *shared = part;
}

/* Starts loading the record and packed fat box pass 2 writes, ahead. */
LC_INLINE void write_prefetch(const locd_scene *s, const uint32_t *d, size_t k, size_t e)
{
    if (k + LC_AHEAD < e) {
        const uint32_t ahead = d[k + LC_AHEAD];
        if ((s->slots.flags[ahead] & (LC_SLOT_LIVE | LC_SLOT_LISTED)) == (LC_SLOT_LIVE | LC_SLOT_LISTED)) {
            const char *h = (const char *)&s->entries.rec[s->entries.dense[ahead]];
            __builtin_prefetch(h, 1);
            __builtin_prefetch(h + sizeof(lc_record) - 1, 1);
            __builtin_prefetch(s->entries.qfat + LC_FAT_WORDS * (size_t)s->entries.dense[ahead], 1);
        }
    }
}

/* Where pass 2 writes a part's rows: undo row, entries, moved lists. */
typedef struct write_at {
    size_t w, q, del[2], add[2], stay, srch;
} write_at;

/* A searching object's rows: its query entries; its old entries (to
 * delete) and new ones (to add) when its cells changed; then its cells,
 * dense index, record and packed fat box. */
LC_INLINE void write_search(lc_update *u, uint32_t slot, uint8_t f, uint32_t di, const lc_cells *c, const uint64_t *q,
                            write_at *at, size_t *reenc)
{
    locd_scene *s = u->s;
    lc_entries *en = &s->entries;
    const locd_grid *g = &en->grid;
    const int l = (f & LC_SLOT_STATIC) ? 1 : 0;
    const uint32_t cnt = lc_cells_entries(g, c, di, u->buf + at->q);
    if (!((f & LC_SLOT_LISTED) && lc_cells_same(c, &en->cell[slot]))) {
        if (f & LC_SLOT_LISTED)
            at->del[l] += lc_cells_entries(g, &en->cell[slot], di, u->buf + at->del[l]);
        memcpy(u->buf + at->add[l], u->buf + at->q, cnt * sizeof(uint64_t));
        at->add[l] += cnt;
        ++*reenc;
    }
    at->q += cnt;
    en->cell[slot] = *c;
    en->dense[slot] = di;
    if ((f & (LC_SLOT_LISTED | LC_SLOT_REFILTER)) == LC_SLOT_LISTED) { /* moved only: the filter is as it was */
        en->rec[di].qlo = q[2], en->rec[di].qhi = q[3];
    } else {
        lc_record_fill(&s->slots, slot, q, &en->rec[di]);
    }
    en->rec[di].flags |= LC_SLOT_DIRTY | LC_REC_SEARCH;
    memcpy(en->qfat + LC_FAT_WORDS * (size_t)di, q, LC_FAT_WORDS * sizeof *q);
    s->slots.flags[slot] |= LC_SLOT_LISTED;
}

/* Pass 2 (the counts' local copy as in survey). */
static void write_part(lc_update *u, lc_encode_part *shared)
{
    locd_scene *s = u->s;
    lc_entries *en = &s->entries;
    lc_undo *un = &u->undo;
    const uint32_t *d = s->slots.dirty.data;
    lc_encode_part part = *shared, *pt = &part;
    write_at at = {pt->live, pt->nq, {pt->ndel[0], pt->ndel[1]}, {pt->nadd[0], pt->nadd[1]}, pt->nstay, pt->nsrch};
    uint32_t fresh = (uint32_t)pt->fresh;
    size_t k;
    for (k = pt->b; k < pt->e; k++) {
        const uint32_t slot = d[k];
        const uint8_t f = s->slots.flags[slot];
        const uint64_t *q = u->new_q + LC_QPAIR * k;
        const lc_cells c = u->new_cells[k];
        uint32_t di;
        write_prefetch(s, d, k, pt->e);
        if (!(f & LC_SLOT_LIVE))
            continue;
        di = (f & LC_SLOT_LISTED) ? en->dense[slot] : fresh++; /* one new to the lists takes the next index */
        un->slot[at.w] = slot;
        un->dense[at.w] = en->dense[slot];
        un->rec[at.w] = en->rec[di];
        if (c.pad[0]) { /* stays in its fat box: only its record changes */
            un->flags[at.w++] = f | LC_UNDO_RECORD;
            en->rec[di].qlo = q[2], en->rec[di].qhi = q[3];
            en->rec[di].flags |= LC_SLOT_DIRTY;
            u->stay[at.stay++] = di;
            continue;
        }
        un->cells[at.w] = en->cell[slot];
        memcpy(un->qfat + LC_FAT_WORDS * at.w, en->qfat + LC_FAT_WORDS * (size_t)di, LC_FAT_WORDS * sizeof *en->qfat);
        un->flags[at.w++] = f;
        u->srch[at.srch++] = di;
        write_search(u, slot, f, di, &c, q, &at, &pt->reenc);
    }
    shared->reenc = pt->reenc;
}

static void task_encode(void *arg, uint32_t t, uint32_t k)
{
    lc_encode_plan *p = arg;
    (void)k;
    if (p->pass == 1)
        survey_part(p->u, &p->part[t]);
    else
        write_part(p->u, &p->part[t]);
}

void lc_encode_plan_init(lc_encode_plan *p, lc_update *u)
{
    const locd_scene *s = u->s;
    const size_t n = s->slots.ndirty;
    uint32_t t;
    p->u = u;
    p->k = s->threads > 1 && n >= LC_ENCODE_SPLIT ? s->threads : 1;
    for (t = 0; t < p->k; t++) {
        memset(&p->part[t], 0, sizeof p->part[t]);
        p->part[t].b = n * t / p->k, p->part[t].e = n * (t + 1) / p->k;
    }
}

void lc_encode_run(lc_encode_plan *p, int pass)
{
    p->pass = pass;
    if (p->k > 1)
        lc_pool_run(p->u->s->pool, p->k, task_encode, p);
    else
        task_encode(p, 0, 1);
}
