/* The pairs of the moved objects. One that stayed in its fat box reads its
 * partner list (stay_one). One that searches (new, re-filtered, or out of
 * its fat box) searches the repaired entry lists: for each entry (cell c,
 * object m), the objects on a common root-to-leaf path with c are the
 * entries of c's subtree (one range of the sorted list: same cell and
 * descendants) and of c's ancestors (one exact key per level that holds any
 * entry). Each candidate is tested in this order: the packed fat boxes
 * (conservative: they meet whenever the boxes do) and the canonical cell
 * pair, from 16 bytes of o (qfat); then o's record: both searched and not
 * m < o (the other one reports it), the filter (static-static,
 * category/mask, group: a filtered pair is never box-tested nor reported);
 * then the boxes' own test (lc_records_meet: the packed boxes, the stored
 * coordinates on a tie). The records of one cell's objects are neighbours
 * (dense indices, scene.h).
 *
 * The canonical cell pair makes each pair come out once however many cells
 * the two objects share paths in: the point p = max(lo_m, lo_o) (sweep
 * coordinates) lies in both packed fat boxes when they meet, so in exactly
 * one cell of each, and those two cells lie on one path; the pair is
 * considered at that cell pair only (docs/scene.md). */
#include "scene/scene.h"
#include "scene/search.h"

/* Below this many query entries and staying objects the search runs on one thread. */
#define LC_SEARCH_SPLIT 2048

/* One thread's output, on its own stack while it runs (no two threads
 * write one cache line) and copied to the context at its end. */
/* Candidates waiting for their test, their boxes being prefetched. The
 * queue runs across query entries, so that a query with few candidates
 * still overlaps its misses with the next ones'. The last ones queued
 * have the least time to arrive: 128 rather than 64 gave them more
 * (`ms_sweep` of a 1%-moved frame of 10^6 cubes, about 4% less; 32 was
 * 12% more; flushing the older half each time the queue fills was slower:
 * fewer records in flight in the second round). */
#define LC_GATHER 128

/* The ancestor ranges last looked up, per array searched and level: the
 * query entries come in key order, so neighbouring ones share their
 * shallow ancestors, whose lookups are then made once. */
typedef struct anc_cache {
    uint64_t key[32];
    size_t b[32], e[32];
} anc_cache;

/* A thread's outputs: rows (two ids); the fat partners found, uint32 (m,
 * o | LC_PAIRED when the boxes meet); the partner-list pass's changed
 * pairs, uint32 (m, k, o | LC_PAIRED now) where k is o's place in m's
 * list. */
enum { FO_ROWS, FO_FAT, FO_EV, FO_N };
static const size_t fo_unit[FO_N] = {2 * sizeof(locd_id), 2 * sizeof(uint32_t), 3 * sizeof(uint32_t)};

typedef struct search_out {
    lc_buf buf[FO_N];
    size_t len[FO_N];
    uint64_t cand;
    locd_status st;
    uint32_t ng;
    uint64_t gq[LC_GATHER], go[LC_GATHER]; /* query entry, candidate entry */
    anc_cache anc[4];                      /* dyn main, dyn overflow, sta main, sta overflow */
} search_out;

typedef struct search_ctx {
    const locd_scene *s;
    const lc_entry_list *dyn, *sta;
    const uint64_t *q; /* sorted entries of the moved objects that search */
    size_t nq;
    const uint32_t *stay; /* the moved objects that take their partner lists */
    size_t nstay;
    int events; /* LC_SEARCH_EVENTS: fat partners and changes, no rows */
    search_out out[]; /* one per thread that runs (each some 5 KB: only those are allocated) */
} search_ctx;

/* The point p lies in the cell (pm, level). */
static int cell_holds(const locd_grid *g, uint64_t pm, uint32_t level, const uint32_t *p)
{
    uint64_t m = pm >> (3u * (g->depth - level));
    uint32_t sh = LC_SBITS - level;
    return lc_morton_compact3(m) == (p[0] >> sh) && lc_morton_compact3(m >> 1) == (p[1] >> sh) &&
           lc_morton_compact3(m >> 2) == (p[2] >> sh);
}

#define FIELD(w, a) ((uint32_t)(((w) >> ((a)*LC_SBITS)) & LC_SMASK))

/* Room for one more item of output `which`; NULL (and fo->st set) on no memory. */
static void *put(const locd_scene *s, search_out *fo, int which)
{
    if (fo->st == LOCD_OK &&
        lc_buf_reserve(s->alloc, &fo->buf[which], fo_unit[which], fo->len[which] + 1) != LOCD_OK)
        fo->st = LOCD_ERR_NO_MEMORY;
    if (fo->st != LOCD_OK)
        return NULL;
    return (char *)fo->buf[which].data + fo_unit[which] * fo->len[which]++;
}

/* The row of the pair of records hm and ho. */
static void put_row(const locd_scene *s, search_out *fo, const lc_record *hm, const lc_record *ho)
{
    locd_id *row = put(s, fo, FO_ROWS);
    if (!row)
        return;
    row[0] = hm->id < ho->id ? hm->id : ho->id;
    row[1] = hm->id < ho->id ? ho->id : hm->id;
}

/* The second test of a candidate entry eo whose packed fat box meets the
 * query entry eq's (object m, record hm): the canonical cell pair. */
static int consider_cell(const search_ctx *c, uint64_t eq, const uint64_t *qm, uint64_t eo, const uint64_t *qo)
{
    const locd_grid *g = &c->s->entries.grid;
    const uint32_t ib = g->index_bits;
    uint32_t lm = (uint32_t)(eq >> ib) & 31u, lo = (uint32_t)(eo >> ib) & 31u, p[3], a;
    for (a = 0; a < 3; a++) {
        uint32_t ml = FIELD(qm[0], a), ol = FIELD(qo[0], a);
        p[a] = ml > ol ? ml : ol;
    }
    return lm >= lo ? cell_holds(g, eq >> (ib + LC_LEVEL_BITS), lm, p)
                    : cell_holds(g, eo >> (ib + LC_LEVEL_BITS), lo, p);
}

/* The rest, from o's record ho: both searched and not m < o, the filter
 * (a fat partner from here on), the boxes; then the row, or the fat
 * partner with whether the boxes meet. */
static void consider_rest(const search_ctx *c, search_out *fo, const lc_record *hm, const lc_record *ho)
{
    const locd_scene *s = c->s;
    /* both searched: the one with the smaller id reports the pair (one
       that moved without searching has it reported by this one) */
    if ((ho->flags & LC_REC_SEARCH) && ho->id < hm->id)
        return;
    /* the filter, before the box test */
    if ((hm->flags & ho->flags & LC_SLOT_STATIC) || !(hm->cat & ho->mask) || !(ho->cat & hm->mask) ||
        (hm->group == ho->group && hm->group != 0))
        return;
    if (c->events) {
        uint32_t *f = put(s, fo, FO_FAT);
        if (f)
            f[0] = (uint32_t)(hm - s->entries.rec), f[1] = (uint32_t)(ho - s->entries.rec) | (lc_records_meet(&s->slots, hm, ho) ? LC_PAIRED : 0u);
    } else if (lc_records_meet(&s->slots, hm, ho)) {
        put_row(s, fo, hm, ho);
    }
}

/* Tests the gathered candidates in three rounds. The first drops, with no
 * branch on the data, the candidates that are the query object itself, a
 * tombstone or a box its quantized box misses (most of them, which ones at
 * random: a branch there mispredicted on a good share of the candidates);
 * their packed boxes were prefetched by gather. The second tests the
 * canonical cell pair of the few left and prefetches their records, which
 * the third tests (so those misses overlap too). */
static void flush(const search_ctx *c, search_out *fo)
{
    const lc_record *rec = c->s->entries.rec;
    const uint64_t *qfat = c->s->entries.qfat;
    const uint64_t imask = ((uint64_t)1 << c->s->entries.grid.index_bits) - 1;
    uint32_t k, nk = 0, ns = 0, cand = 0;
    uint32_t sk[LC_GATHER], sm[LC_GATHER], so[LC_GATHER];
    for (k = 0; k < fo->ng; k++) {
        const uint32_t m = (uint32_t)(fo->gq[k] & imask), o = (uint32_t)(fo->go[k] & imask);
        const uint32_t real = (uint32_t)(o != m) & (uint32_t)(o != (uint32_t)imask);
        /* a tombstone's index names no record: m's box stands in, unused */
        const uint64_t *qo = qfat + LC_FAT_WORDS * (size_t)(real ? o : m);
        cand += real;
        sk[nk] = k;
        nk += real & !lc_qbox_miss(qfat + LC_FAT_WORDS * (size_t)m, qo);
    }
    fo->cand += cand;
    for (k = 0; k < nk; k++) {
        const uint64_t eq = fo->gq[sk[k]], eo = fo->go[sk[k]];
        const uint32_t m = (uint32_t)(eq & imask), o = (uint32_t)(eo & imask);
        if (consider_cell(c, eq, qfat + LC_FAT_WORDS * (size_t)m, eo, qfat + LC_FAT_WORDS * (size_t)o)) {
            __builtin_prefetch(&rec[o]);
            __builtin_prefetch((const char *)&rec[o] + sizeof(lc_record) - 1);
            sm[ns] = m, so[ns++] = o;
        }
    }
    for (k = 0; k < ns; k++)
        consider_rest(c, fo, &rec[sm[k]], &rec[so[k]]);
    fo->ng = 0;
}

LC_INLINE void gather(const search_ctx *c, search_out *fo, uint64_t eq, uint64_t eo)
{
    const uint64_t imask = ((uint64_t)1 << c->s->entries.grid.index_bits) - 1;
    __builtin_prefetch(c->s->entries.qfat + LC_FAT_WORDS * (size_t)(eo & imask));
    fo->gq[fo->ng] = eq;
    fo->go[fo->ng++] = eo;
    if (fo->ng == LC_GATHER)
        flush(c, fo);
}

/* The first of e[0, n) >= v: through tr's directory for its main array. */
static size_t lower(const lc_entry_list *tr, const uint64_t *e, size_t n, uint64_t v)
{
    return e == tr->ent.data ? lc_entry_list_lower_bound(tr, v) : lc_lower_bound(e, n, v);
}

/* Every entry of e[0, n) (tr's main array or overflow) on a common path
 * with the cell of entry eq; ac caches this array's ancestor ranges. */
static void search_array(const search_ctx *c, search_out *fo, const lc_entry_list *tr, const uint64_t *e, size_t n,
                         uint64_t eq, anc_cache *ac)
{
    const size_t *per_level = tr->per_level;
    const locd_grid *g = &c->s->entries.grid;
    const uint32_t ib = g->index_bits;
    const uint64_t key = eq >> ib, pm = key >> LC_LEVEL_BITS;
    const uint32_t level = (uint32_t)key & 31u;
    size_t i;
    uint32_t l;
    if (!n)
        return;
    /* The candidates are gathered first and their packed boxes prefetched,
       so that their cache misses overlap instead of following each other
       (each test branches on the data it loads). */
    /* the cell itself and its descendants: keys in [key, (pm + span) << 5) */
    {
        const uint64_t end = (pm + ((uint64_t)1 << (3u * (g->depth - level)))) << LC_LEVEL_BITS;
        for (i = lower(tr, e, n, key << ib); i < n && (e[i] >> ib) < end; i++)
            gather(c, fo, eq, e[i]);
    }
    /* its ancestors, at the levels that hold entries */
    for (l = 0; l < level; l++) {
        uint64_t ka;
        size_t b, x;
        if (!per_level[l])
            continue;
        ka = ((pm & ~(((uint64_t)1 << (3u * (g->depth - l))) - 1)) << LC_LEVEL_BITS) | l;
        if (ac->key[l] != ka) {
            b = lower(tr, e, n, ka << ib);
            for (i = b; i < n && (e[i] >> ib) == ka; i++)
                ;
            ac->key[l] = ka, ac->b[l] = b, ac->e[l] = i;
        }
        for (x = ac->b[l]; x < ac->e[l]; x++)
            gather(c, fo, eq, e[x]);
    }
}

static void search(const search_ctx *c, search_out *fo, const lc_entry_list *tr, uint64_t eq, anc_cache *ac)
{
    if (tr->count)
        search_array(c, fo, tr, tr->ent.data, tr->count, eq, ac);
    if (tr->novf)
        search_array(c, fo, tr, tr->ovf.data, tr->novf, eq, ac + 1);
}

/* How many query entries ahead the main arrays' lookups are started, and
 * how many ahead their directory entries are asked for: the lookup's
 * prefetch reads the directory entry to know where to load from, and that
 * read was itself a miss (a tenth of a 1%-moved frame's search). */
#define LC_LOOK_AHEAD 16
#define LC_DIR_AHEAD 48

/* The directory entry of tr's main array for query entry eq (as
 * lc_entry_list_lower_bound finds it), or SIZE_MAX when tr has none. */
LC_INLINE size_t dir_slot(const search_ctx *c, const lc_entry_list *tr, uint64_t eq)
{
    const uint32_t ib = c->s->entries.grid.index_bits;
    size_t j;
    if (!tr->dir || !tr->count)
        return SIZE_MAX;
    j = (size_t)(((eq >> ib) << ib) >> tr->dir_shift);
    return j < ((size_t)1 << tr->dir_bits) ? j : SIZE_MAX;
}

/* Starts loading the part of tr's main array where the cell of query
 * entry eq lies (its directory bucket). */
LC_INLINE void prefetch_lookup(const search_ctx *c, const lc_entry_list *tr, uint64_t eq)
{
    const size_t j = dir_slot(c, tr, eq);
    if (j != SIZE_MAX) {
        /* the bucket (about 8 entries) and the cell's run that may go on
           past it (a dozen entries a cell): four lines */
        const uint64_t *b = (const uint64_t *)tr->ent.data + tr->dir[j];
        __builtin_prefetch(b);
        __builtin_prefetch(b + 8);
        __builtin_prefetch(b + 16);
        __builtin_prefetch(b + 24);
    }
}

/* Starts loading tr's directory entry for query entry eq. */
LC_INLINE void prefetch_dir(const search_ctx *c, const lc_entry_list *tr, uint64_t eq)
{
    const size_t j = dir_slot(c, tr, eq);
    if (j != SIZE_MAX)
        __builtin_prefetch(tr->dir + j);
}

/* Starts loading the directory entries of query entry eq (in the dynamic
 * and the static list) and its object's record. */
LC_INLINE void prefetch_far(const search_ctx *c, uint64_t eq)
{
    const lc_record *h = &c->s->entries.rec[eq & (((uint64_t)1 << c->s->entries.grid.index_bits) - 1)];
    prefetch_dir(c, c->dyn, eq);
    prefetch_dir(c, c->sta, eq);
    __builtin_prefetch(h);
    __builtin_prefetch((const char *)h + sizeof *h - 1);
}

/* Starts the lookups of query entry eq: when its turn comes they are
 * hits, their misses overlapped with the ones of the query entries before
 * it. */
LC_INLINE void prefetch_query(const search_ctx *c, uint64_t eq)
{
    prefetch_lookup(c, c->dyn, eq);
    if (c->sta->count)
        prefetch_lookup(c, c->sta, eq);
}

/* How many moved objects ahead the partner-list pass starts loading a
 * list's header, then its entries and the object's own record and boxes,
 * then its partners' records and boxes: three rounds of misses, each
 * overlapped with the work on the objects before. */
#define LC_STAY_HEAD 24
#define LC_STAY_LIST 12
#define LC_STAY_PART 4

/* The pairs of moved object m from its partner list: a partner that
 * searched reports the pair itself, a removed one its loss; of two that
 * both took their lists, the one with the smaller id does. Rows: m's pairs.
 * Events: the partners whose pairing changed (the list's PAIRED bit is the
 * previous set's). */
static void stay_one(const search_ctx *c, search_out *fo, uint32_t m)
{
    const locd_scene *s = c->s;
    const lc_partner_list *h = &s->partners.list[m];
    const uint32_t *v = s->partners.pool + h->off;
    const lc_record *hm = &s->entries.rec[m];
    uint32_t k;
    for (k = 0; k < h->n; k++) {
        const uint32_t o = v[k] & LC_INDEX_BITS;
        const lc_record *ho = &s->entries.rec[o];
        uint32_t meet;
        if ((ho->flags & (LC_REC_SEARCH | LC_REC_GONE)) || ((ho->flags & LC_SLOT_DIRTY) && ho->id < hm->id))
            continue;
        fo->cand++;
        meet = (uint32_t)lc_records_meet(&s->slots, hm, ho);
        if (!c->events) {
            if (meet)
                put_row(s, fo, hm, ho);
        } else if (meet != (v[k] >> 31)) {
            uint32_t *e = put(s, fo, FO_EV);
            if (e)
                e[0] = m, e[1] = k, e[2] = o | (meet << 31);
        }
    }
}

LC_INLINE void prefetch_record(const locd_scene *s, uint32_t d)
{
    __builtin_prefetch(&s->entries.rec[d]);
    __builtin_prefetch((const char *)&s->entries.rec[d] + sizeof(lc_record) - 1);

}

static void stay_range(const search_ctx *c, search_out *fo, size_t b, size_t e)
{
    const locd_scene *s = c->s;
    const uint32_t *m = c->stay;
    size_t i;
    for (i = b; i < e; i++) {
        if (i + LC_STAY_HEAD < e)
            __builtin_prefetch(&s->partners.list[m[i + LC_STAY_HEAD]]);
        if (i + LC_STAY_LIST < e) {
            __builtin_prefetch(s->partners.pool + s->partners.list[m[i + LC_STAY_LIST]].off);
            prefetch_record(s, m[i + LC_STAY_LIST]);
        }
        if (i + LC_STAY_PART < e) {
            const lc_partner_list *h = &s->partners.list[m[i + LC_STAY_PART]];
            uint32_t k;
            for (k = 0; k < h->n; k++)
                prefetch_record(s, s->partners.pool[h->off + k] & LC_INDEX_BITS);
        }
        stay_one(c, fo, m[i]);
    }
}

static void task_search(void *arg, uint32_t t, uint32_t k)
{
    search_ctx *c = arg;
    const uint64_t imask = ((uint64_t)1 << c->s->entries.grid.index_bits) - 1;
    size_t b = c->nq * t / k, e = c->nq * (t + 1) / k, i;
    search_out fo;
    memset(&fo, 0, offsetof(search_out, gq)); /* (the queue's entries are written before they are read) */
    memset(fo.anc, 0xff, sizeof fo.anc); /* no key: a key's level bits are at most LC_SBITS */
    for (i = b; i < b + LC_DIR_AHEAD && i < e; i++)
        prefetch_far(c, c->q[i]);
    for (i = b; i < b + LC_LOOK_AHEAD && i < e; i++)
        prefetch_query(c, c->q[i]);
    for (i = b; i < e; i++) {
        const lc_record *hm = &c->s->entries.rec[c->q[i] & imask];
        if (i + LC_DIR_AHEAD < e)
            prefetch_far(c, c->q[i + LC_DIR_AHEAD]);
        if (i + LC_LOOK_AHEAD < e)
            prefetch_query(c, c->q[i + LC_LOOK_AHEAD]);
        search(c, &fo, c->dyn, c->q[i], fo.anc);
        if (!(hm->flags & LC_SLOT_STATIC))
            search(c, &fo, c->sta, c->q[i], fo.anc + 2);
    }
    flush(c, &fo);
    stay_range(c, &fo, c->nstay * t / k, c->nstay * (t + 1) / k);
    c->out[t] = fo;
}

/* Each thread's output `which`, one after another, into out (*len items). */
static locd_status gather_out(const locd_scene *s, const search_ctx *c, uint32_t k, int which, lc_buf *out, size_t *len)
{
    size_t total = 0, w = 0;
    uint32_t t;
    for (t = 0; t < k; t++)
        total += c->out[t].len[which];
    if (lc_buf_reserve(s->alloc, out, fo_unit[which], total ? total : 1) != LOCD_OK)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not gather the search's output");
    for (t = 0; t < k; t++) {
        if (c->out[t].len[which])
            memcpy((char *)out->data + fo_unit[which] * w, c->out[t].buf[which].data,
                   fo_unit[which] * c->out[t].len[which]);
        w += c->out[t].len[which];
    }
    *len = w;
    return LOCD_OK;
}

locd_status lc_search_moved(const locd_scene *s, const lc_moved *m, int mode, lc_search_out *out)
{
    const uint32_t k = s->threads > 1 && m->nq + m->nstay >= LC_SEARCH_SPLIT ? s->threads : 1;
    const size_t size = offsetof(search_ctx, out) + k * sizeof(search_out);
    search_ctx *c = lc_alloc(s->alloc, size);
    uint32_t t;
    locd_status st = LOCD_OK;
    if (!c)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the search state");
    memset(c, 0, offsetof(search_ctx, out)); /* (each thread writes its output whole) */
    c->s = s, c->dyn = m->dyn, c->sta = m->sta, c->q = m->q, c->nq = m->nq;
    c->stay = m->stay, c->nstay = m->nstay, c->events = mode == LC_SEARCH_EVENTS;
    if (k > 1)
        lc_pool_run(s->pool, k, task_search, c);
    else
        task_search(c, 0, 1);
    for (t = 0; t < k; t++) {
        if (c->out[t].st != LOCD_OK)
            st = lc_error(LOCD_ERR_NO_MEMORY, "could not grow the new pairs");
        out->candidates += c->out[t].cand;
    }
    out->nfat = out->nev = 0;
    out->rows.count = out->rows.first = 0;
    if (st == LOCD_OK && c->events && (st = gather_out(s, c, k, FO_FAT, &out->fat, &out->nfat)) == LOCD_OK)
        st = gather_out(s, c, k, FO_EV, &out->ev, &out->nev);
    if (st == LOCD_OK && !c->events && (st = gather_out(s, c, k, FO_ROWS, &out->rows.rows, &out->rows.count)) == LOCD_OK)
        st = lc_pair_rows_sort(s->alloc, out->rows.rows.data, out->rows.count);
    for (t = 0; t < k; t++) {
        int w;
        for (w = 0; w < FO_N; w++)
            lc_buf_release(s->alloc, &c->out[t].buf[w], fo_unit[w]);
    }
    lc_free(s->alloc, c, size);
    return st;
}

void lc_search_out_fini(const locd_allocator *a, lc_search_out *o)
{
    lc_pair_list_fini(a, &o->rows);
    lc_buf_release(a, &o->fat, 2 * sizeof(uint32_t));
    lc_buf_release(a, &o->ev, 3 * sizeof(uint32_t));
}
