/* Partner lists: for each object in the entry lists, the objects whose fat
 * boxes meet its fat box (packed sweep boxes, closed) and that may pair
 * with it (the filter). A moved object still inside its fat box takes its
 * pairs from this list instead of searching the entry lists: any object its
 * box overlaps is in it (docs/scene.md).
 *
 * The relation changes only when a fat box or a filter does, and each
 * such change makes the object search (incremental.c); the search gives its
 * new partners, and the update takes it off its old partners' lists and
 * links the new ones. So the lists are always the relation, symmetric, with
 * no pair twice.
 *
 * Storage: one pool of dense indices, each object's list a run in it with
 * some room; a list that outgrows its run moves to the pool's end, and the
 * pool is packed again when it must grow. */
#include "scene/scene.h"

/* Room given to a list beyond its entries, at a build and at a move. */
LC_INLINE uint32_t room_for(uint32_t n)
{
    return n + n / 4 + 2;
}

void lc_partners_drop(locd_scene *s)
{
    lc_free(s->alloc, s->partners.list, s->partners.heads * sizeof *s->partners.list);
    lc_free(s->alloc, s->partners.pool, s->partners.cap * sizeof *s->partners.pool);
    s->partners.list = NULL, s->partners.pool = NULL;
    s->partners.heads = s->partners.used = s->partners.cap = s->partners.live = 0;
    s->partners.valid = 0;
}

/* A may pair with b (the records' filter; the lists hold no other pair).
 * A removed object's record stays (its dense index is not given again
 * before the lists are built from scratch) with LC_REC_GONE: it has no
 * partners. */
LC_INLINE int records_may_pair(const lc_record *a, const lc_record *b)
{
    return !((a->flags | b->flags) & LC_REC_GONE) && !(a->flags & b->flags & LC_SLOT_STATIC) &&
           (a->cat & b->mask) && (b->cat & a->mask) && !(a->group == b->group && a->group != 0);
}

/* The pairs of the packed fat boxes of dense indices [0, n), by the
 * engine's find (into s->found): the boxes in sweep units, integers below
 * 2^21, floats exactly, so the engine's closed test on them is the packed
 * boxes' test. */
static locd_status fat_pairs(locd_scene *s, size_t n)
{
    const size_t cap = (n ? n : 1) * 6;
    float *fb = lc_alloc(s->alloc, cap * sizeof *fb);
    locd_stats st_find;
    locd_status st;
    size_t k;
    if (!fb)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the partner lists");
    for (k = 0; k < n; k++) {
        const uint64_t *q = s->entries.qfat + LC_FAT_WORDS * k;
        uint32_t ax;
        for (ax = 0; ax < 3; ax++) {
            fb[6 * k + ax] = (float)((q[0] >> (ax * LC_SBITS)) & LC_SMASK);
            fb[6 * k + 3 + ax] = (float)((q[1] >> (ax * LC_SBITS)) & LC_SMASK);
        }
    }
    locd_stats_init(&st_find);
    st = s->engine->ops->find(s->engine, fb, n, 0, 0, &s->found, &st_find);
    lc_free(s->alloc, fb, cap * sizeof *fb);
    return st;
}

/* The runs: each list's length counted (in n), its run placed with room;
 * then the pool. 0 on no memory. */
static int place_runs(locd_scene *s, const uint32_t *p, size_t np, size_t n)
{
    lc_partners *pa = &s->partners;
    size_t k, total = 0;
    for (k = 0; k < np; k++) {
        const uint32_t i = p[2 * k], j = p[2 * k + 1];
        if (records_may_pair(&s->entries.rec[i], &s->entries.rec[j]))
            pa->list[i].n++, pa->list[j].n++;
    }
    for (k = 0; k < n; k++) {
        pa->list[k].off = (uint32_t)total;
        pa->list[k].cap = room_for(pa->list[k].n);
        total += pa->list[k].cap;
        pa->live += pa->list[k].n;
        pa->list[k].n = 0;
    }
    if (total > UINT32_MAX - (total >> 2) - 64)
        return 0;
    pa->cap = total + (total >> 3) + 64;
    pa->used = total;
    return (pa->pool = lc_alloc(s->alloc, pa->cap * sizeof *pa->pool)) != NULL;
}

locd_status lc_partners_build(locd_scene *s)
{
    lc_partners *pa = &s->partners;
    const size_t n = s->entries.ndense, heads = s->entries.cap;
    const lc_record *rec = s->entries.rec;
    const uint32_t *p;
    size_t k, np;
    locd_status st;
    lc_partners_drop(s);
    if (heads > LC_INDEX_BITS) /* an entry keeps one bit for PAIRED */
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "too many objects for partner lists");
    if (!(pa->list = lc_alloc(s->alloc, heads * sizeof *pa->list)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the partner lists");
    pa->heads = heads;
    memset(pa->list, 0, heads * sizeof *pa->list);
    if ((st = fat_pairs(s, n)) != LOCD_OK) {
        lc_partners_drop(s);
        return st;
    }
    p = s->found.data, np = s->found.count;
    if (!place_runs(s, p, np, n)) {
        lc_partners_drop(s);
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the partner lists");
    }
    for (k = 0; k < np; k++) {
        const uint32_t i = p[2 * k], j = p[2 * k + 1];
        if (records_may_pair(&rec[i], &rec[j])) {
            const uint32_t paired = lc_records_meet(&s->slots, &rec[i], &rec[j]) ? LC_PAIRED : 0u;
            pa->pool[pa->list[i].off + pa->list[i].n++] = j | paired;
            pa->pool[pa->list[j].off + pa->list[j].n++] = i | paired;
        }
    }
    pa->valid = 1;
    return LOCD_OK;
}

void lc_partners_unlink(locd_scene *s, uint32_t d)
{
    lc_partner_list *h = &s->partners.list[d];
    uint32_t k;
    for (k = 0; k < h->n; k++) {
        lc_partner_list *ho = &s->partners.list[s->partners.pool[h->off + k] & LC_INDEX_BITS];
        uint32_t *v = s->partners.pool + ho->off, x;
        for (x = 0; x < ho->n; x++)
            if ((v[x] & LC_INDEX_BITS) == d) {
                v[x] = v[--ho->n];
                break;
            }
    }
    s->partners.live -= 2 * (size_t)h->n;
    h->n = 0;
}

/* Room for `need` more pool entries at its end: the pool packed into a new
 * one (each list with room) when it is full. 0 on no memory. */
static int pool_room(locd_scene *s, size_t need)
{
    size_t k, total = 0, cap;
    uint32_t *pool;
    if (s->partners.used + need <= s->partners.cap)
        return 1;
    for (k = 0; k < s->partners.heads; k++)
        total += s->partners.list[k].n ? room_for(s->partners.list[k].n) : 0;
    cap = total + need;
    cap += cap / 2 + 64;
    if (cap > UINT32_MAX || !(pool = lc_alloc(s->alloc, cap * sizeof *pool)))
        return 0;
    total = 0;
    for (k = 0; k < s->partners.heads; k++) {
        lc_partner_list *h = &s->partners.list[k];
        if (!h->n) {
            h->off = 0, h->cap = 0;
            continue;
        }
        memcpy(pool + total, s->partners.pool + h->off, h->n * sizeof *pool);
        h->off = (uint32_t)total, h->cap = room_for(h->n);
        total += h->cap;
    }
    lc_free(s->alloc, s->partners.pool, s->partners.cap * sizeof *s->partners.pool);
    s->partners.pool = pool, s->partners.cap = cap, s->partners.used = total;
    return 1;
}

/* Appends b to a's list, moving the list to the pool's end when full. */
static int push(locd_scene *s, uint32_t a, uint32_t b)
{
    lc_partner_list *h = &s->partners.list[a];
    if (h->n == h->cap) {
        const uint32_t cap = 2 * h->cap + 4;
        if (!pool_room(s, cap))
            return 0;
        h = &s->partners.list[a];
        memcpy(s->partners.pool + s->partners.used, s->partners.pool + h->off, h->n * sizeof *s->partners.pool);
        h->off = (uint32_t)s->partners.used, h->cap = cap;
        s->partners.used += cap;
    }
    s->partners.pool[h->off + h->n++] = b;
    return 1;
}

void lc_partners_link(locd_scene *s, uint32_t a, uint32_t b, int paired)
{
    const uint32_t bit = paired ? LC_PAIRED : 0u;
    if (!s->partners.valid)
        return;
    if (!push(s, a, b | bit) || !push(s, b, a | bit)) {
        lc_partners_drop(s); /* the scene searches every moved object until the lists are built again */
        return;
    }
    s->partners.live += 2;
}

void lc_partners_set_paired(locd_scene *s, uint32_t a, uint32_t k, uint32_t b, int paired)
{
    const lc_partner_list *hb = &s->partners.list[b];
    uint32_t *v = s->partners.pool + hb->off, x;
    uint32_t *e = s->partners.pool + s->partners.list[a].off + k;
    *e = (*e & LC_INDEX_BITS) | (paired ? LC_PAIRED : 0u);
    for (x = 0; x < hb->n; x++)
        if ((v[x] & LC_INDEX_BITS) == a) {
            v[x] = a | (paired ? LC_PAIRED : 0u);
            break;
        }
}
