/* The scene's entry lists built from every live object: each object's
 * cells and packed boxes on a grid fitted to the boxes, its entries in the
 * dynamic or the static list, sorted; then the objects numbered in the
 * order of the sorted lists (the dense index) and their records filled.
 * The passes over the slots run on the pool: thread t takes slots
 * [b[t], b[t+1]), computes their cells and counts their entries (pass 1),
 * then writes its entries in its own region of each list's run buffer in
 * slot order (pass 2); lc_psort sorts the regions into the lists. Pass 3
 * fills the records of dense indices [b[t], b[t+1]) once numbered. */
#include "scene/scene.h"

/* How far ahead the passes over slots in entry order (scattered) load
 * what they read: the numbering reads dense[slot], the records the slot
 * arrays. Taken one after another, on one thread, these misses made the
 * numbering most of a build at 10^6 objects. */
#define LC_NUMBER_AHEAD 16
/* Below this many slots (dense indices for pass 3) the passes run on one thread. */
#define LC_BUILD_SPLIT 16384

void lc_record_fill(const lc_slots *sl, size_t k, const uint64_t qbox[LC_QPAIR], lc_record *r)
{
    r->qlo = qbox[2];
    r->qhi = qbox[3];
    r->pad = 0;
    r->cat = sl->cat[k];
    r->mask = sl->mask[k];
    r->group = sl->group[k];
    r->slot = (uint32_t)k;
    r->id = sl->id[k];
    r->flags = sl->flags[k] & LC_SLOT_STATIC;
}

typedef struct build_ctx {
    const lc_slots *sl;
    lc_entries *e;  /* the new lists */
    uint64_t *qb;   /* LC_QPAIR per slot: the packed fat box and box */
    size_t b[LC_MAX_THREADS + 1];
    uint32_t k;
    size_t cnt[2][LC_MAX_THREADS], off[2][LC_MAX_THREADS];
    uint64_t *ent[2];    /* pass 2: the dynamic and the static entries' regions */
    const uint32_t *ord; /* pass 3: the slot of each dense index */
    int pass;
} build_ctx;

/* Pass 1: the cells and packed boxes of slots [b, e), and their entries
 * counted per list. */
static void count_cells(build_ctx *c, uint32_t t)
{
    const lc_slots *sl = c->sl;
    size_t n[2] = {0, 0}, j;
    for (j = c->b[t]; j < c->b[t + 1]; j++) {
        double tmp[6];
        if (!(sl->flags[j] & LC_SLOT_LIVE))
            continue;
        lc_cells_of(&c->e->grid, lc_slot_box(sl, j, tmp), &c->e->cell[j], c->qb + LC_QPAIR * j);
        n[(sl->flags[j] & LC_SLOT_STATIC) ? 1 : 0] += lc_cells_count(&c->e->cell[j]);
    }
    c->cnt[0][t] = n[0], c->cnt[1][t] = n[1];
}

/* Pass 2: the entries of slots [b, e), the slot as their index for now. */
static void write_entries(build_ctx *c, uint32_t t)
{
    const lc_slots *sl = c->sl;
    size_t w[2] = {0, 0}, j;
    for (j = c->b[t]; j < c->b[t + 1]; j++) {
        int kind;
        if (!(sl->flags[j] & LC_SLOT_LIVE))
            continue;
        kind = (sl->flags[j] & LC_SLOT_STATIC) ? 1 : 0;
        w[kind] += lc_cells_entries(&c->e->grid, &c->e->cell[j], (uint32_t)j, c->ent[kind] + c->off[kind][t] + w[kind]);
    }
}

/* Pass 3: the records and packed fat boxes of dense indices [b, e). */
static void fill_records(build_ctx *c, uint32_t t)
{
    const lc_slots *sl = c->sl;
    const size_t b = c->b[t], e = c->b[t + 1];
    size_t d;
    for (d = b; d < e; d++) {
        const uint32_t slot = c->ord[d];
        if (d + LC_NUMBER_AHEAD < e) {
            const uint32_t a = c->ord[d + LC_NUMBER_AHEAD];
            __builtin_prefetch(sl->cat + a);
            __builtin_prefetch(sl->mask + a);
            __builtin_prefetch(sl->group + a);
            __builtin_prefetch(sl->id + a);
            __builtin_prefetch(sl->flags + a);
            __builtin_prefetch(c->qb + LC_QPAIR * (size_t)a);
        }
        lc_record_fill(sl, slot, c->qb + LC_QPAIR * (size_t)slot, &c->e->rec[d]);
        memcpy(c->e->qfat + LC_FAT_WORDS * d, c->qb + LC_QPAIR * (size_t)slot, LC_FAT_WORDS * sizeof *c->e->qfat);
    }
}

static void task_build(void *arg, uint32_t t, uint32_t k)
{
    build_ctx *c = arg;
    (void)k;
    if (c->pass == 1)
        count_cells(c, t);
    else if (c->pass == 2)
        write_entries(c, t);
    else
        fill_records(c, t);
}

/* Pass `pass` over n items in c->k ranges (one thread below LC_BUILD_SPLIT). */
static void build_run(locd_scene *s, build_ctx *c, int pass, size_t n)
{
    uint32_t t;
    c->k = n < LC_BUILD_SPLIT ? 1 : (s->threads ? s->threads : 1);
    for (t = 0; t <= c->k; t++)
        c->b[t] = n * t / c->k;
    c->pass = pass;
    if (c->k > 1)
        lc_pool_run(s->pool, c->k, task_build, c);
    else
        task_build(c, 0, 1);
}

/* Pass 2 into regions of scr (the dynamic list's part, then the static
 * one's: equal keys in index order, as lc_psort wants), then each list
 * sorted by key. */
static locd_status write_and_sort(locd_scene *s, build_ctx *c, uint64_t *scr, const size_t n[2])
{
    const locd_allocator *a = s->alloc;
    lc_entry_list *ts[2];
    uint32_t t;
    int i;
    ts[0] = &c->e->dyn, ts[1] = &c->e->sta;
    if (lc_buf_reserve(a, &ts[0]->ent, sizeof(uint64_t), n[0] ? n[0] : 1) != LOCD_OK ||
        lc_buf_reserve(a, &ts[1]->ent, sizeof(uint64_t), n[1] ? n[1] : 1) != LOCD_OK)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's entry lists");
    c->ent[0] = scr, c->ent[1] = scr + n[0];
    build_run(s, c, 2, s->slots.nslots);
    for (i = 0; i < 2; i++) {
        lc_psort_in in;
        in.k = c->k, in.index_bits = c->e->grid.index_bits, in.key_bits = LC_LEVEL_BITS + 3 * c->e->grid.depth;
        for (t = 0; t < c->k; t++)
            in.run[t] = c->ent[i] + c->off[i][t], in.count[t] = c->cnt[i][t];
        if (lc_psort(s->pool, a, &in, ts[i]->ent.data, c->ent[i]) != LOCD_OK)
            return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's entry lists");
        ts[i]->count = n[i];
    }
    return LOCD_OK;
}

/* The objects numbered in entry order, the numbers put in the entries (ord:
 * the slot of each number). Keys stay sorted; within one key the order may
 * change, which nothing relies on (entry_list.c). */
static void number(const lc_slots *sl, lc_entries *e, uint32_t *ord)
{
    const uint64_t imask = ((uint64_t)1 << e->grid.index_bits) - 1;
    lc_entry_list *ts[2];
    size_t k, j, next = 0;
    int i;
    for (k = 0; k < sl->nslots; k++)
        e->dense[k] = UINT32_MAX;
    ts[0] = &e->dyn, ts[1] = &e->sta;
    for (i = 0; i < 2; i++) {
        uint64_t *v = ts[i]->ent.data;
        const size_t cnt = ts[i]->count;
        for (j = 0; j < cnt; j++) {
            const uint32_t slot = (uint32_t)(v[j] & imask);
            if (j + LC_NUMBER_AHEAD < cnt)
                __builtin_prefetch(e->dense + (v[j + LC_NUMBER_AHEAD] & imask), 1);
            if (e->dense[slot] == UINT32_MAX) {
                ord[next] = slot;
                e->dense[slot] = (uint32_t)next++;
            }
            v[j] = (v[j] & ~imask) | e->dense[slot];
        }
    }
    e->ndense = next;
}

/* The new lists e of every live object (e's arrays allocated, its grid fitted). */
static locd_status build(locd_scene *s, lc_entries *e)
{
    const locd_allocator *a = s->alloc;
    const size_t qcap = LC_QPAIR * (s->slots.nslots ? s->slots.nslots : 1);
    build_ctx *c = lc_alloc(a, sizeof *c);
    uint64_t *scr = NULL;
    size_t n[2] = {0, 0}, nscr = 1;
    locd_status st = LOCD_OK;
    uint32_t t;
    int i;
    if (!c || (memset(c, 0, sizeof *c), !(c->qb = lc_alloc(a, qcap * sizeof *c->qb)))) {
        st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's entry lists");
        goto done;
    }
    c->sl = &s->slots, c->e = e;
    build_run(s, c, 1, s->slots.nslots);
    for (i = 0; i < 2; i++)
        for (t = 0; t < c->k; t++)
            c->off[i][t] = n[i], n[i] += c->cnt[i][t];
    nscr = n[0] + n[1] ? n[0] + n[1] : 1;
    if (!(scr = lc_alloc(a, nscr * sizeof *scr))) {
        st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's entry lists");
        goto done;
    }
    if ((st = write_and_sort(s, c, scr, n)) != LOCD_OK)
        goto done;
    number(&s->slots, e, (uint32_t *)scr); /* (scr is free again) */
    for (i = 0; i < 2; i++) {
        lc_entry_list_count_levels(&e->grid, i ? &e->sta : &e->dyn);
        lc_entry_list_build_dir(a, &e->grid, i ? &e->sta : &e->dyn);
    }
    c->ord = (uint32_t *)scr;
    build_run(s, c, 3, e->ndense);
done:
    if (c)
        lc_free(a, c->qb, qcap * sizeof *c->qb);
    lc_free(a, scr, nscr * sizeof *scr);
    lc_free(a, c, sizeof *c);
    return st;
}

/* Frees lists e, whose per-slot arrays have slot_cap entries. */
static void entries_free(const locd_allocator *a, lc_entries *e, size_t slot_cap)
{
    lc_entry_list_release(a, &e->dyn);
    lc_entry_list_release(a, &e->sta);
    lc_free(a, e->cell, slot_cap * sizeof *e->cell);
    lc_free(a, e->dense, slot_cap * sizeof *e->dense);
    lc_free(a, e->rec, e->cap * sizeof *e->rec);
    lc_free(a, e->qfat, e->cap * LC_FAT_WORDS * sizeof *e->qfat);
    memset(e, 0, sizeof *e);
}

locd_status lc_entries_build(locd_scene *s)
{
    const locd_allocator *a = s->alloc;
    const size_t slot_cap = s->slots.slot_cap;
    lc_entries e, old;
    locd_status st;
    size_t k;
    memset(&e, 0, sizeof e);
    e.cap = lc_entries_room(s->slots.nslots);
    e.cell = lc_alloc(a, slot_cap * sizeof *e.cell);
    e.dense = lc_alloc(a, slot_cap * sizeof *e.dense);
    e.rec = lc_alloc(a, e.cap * sizeof *e.rec);
    e.qfat = lc_alloc(a, e.cap * LC_FAT_WORDS * sizeof *e.qfat);
    if (!e.cell || !e.dense || !e.rec || !e.qfat)
        st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's cells");
    else if (memset(e.cell, 0, slot_cap * sizeof *e.cell), (st = lc_entries_fit_grid(s, &e.grid)) == LOCD_OK)
        st = build(s, &e);
    if (st != LOCD_OK) {
        entries_free(a, &e, slot_cap);
        return st;
    }
    old = s->entries;
    e.valid = 1;
    s->entries = e;
    entries_free(a, &old, slot_cap);
    for (k = 0; k < s->slots.nslots; k++)
        s->slots.flags[k] = (uint8_t)((s->slots.flags[k] & LC_SLOT_LIVE) ? s->slots.flags[k] | LC_SLOT_LISTED
                                                                         : s->slots.flags[k] & ~LC_SLOT_LISTED);
    return LOCD_OK;
}

void lc_entries_drop(locd_scene *s)
{
    size_t k;
    lc_entry_list_release(s->alloc, &s->entries.dyn);
    lc_entry_list_release(s->alloc, &s->entries.sta);
    memset(&s->entries.dyn, 0, sizeof s->entries.dyn);
    memset(&s->entries.sta, 0, sizeof s->entries.sta);
    if (s->entries.valid) /* else no slot has the flag: the lists were dropped before */
        for (k = 0; k < s->slots.nslots; k++)
            s->slots.flags[k] &= (uint8_t)~LC_SLOT_LISTED;
    s->entries.valid = 0;
}

void lc_entries_fini(locd_scene *s)
{
    entries_free(s->alloc, &s->entries, s->slots.slot_cap);
}
