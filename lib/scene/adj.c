/* Partner lists: for each object in the entry lists, the objects whose fat
 * boxes meet its fat box (packed sweep boxes, closed) and that may pair
 * with it (the filter). A moved object still inside its fat box takes its
 * pairs from this list instead of searching the entry lists: any object its
 * box overlaps is in it (docs/scene.md, "Fat boxes and partner lists").
 *
 * The relation changes only when a fat box or a filter does, and each
 * such change makes the object search (update.c); the search gives its
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

void lc_adj_drop(locd_scene *s)
{
    lc_free(s->alloc, s->adj, s->adj_heads * sizeof *s->adj);
    lc_free(s->alloc, s->adj_pool, s->adj_cap * sizeof *s->adj_pool);
    s->adj = NULL, s->adj_pool = NULL;
    s->adj_heads = s->adj_used = s->adj_cap = s->adj_live = 0;
    s->have_adj = 0;
}

/* A may pair with b (the records' filter; the lists hold no other pair).
 * A removed object's record stays (its dense index is not given again
 * before the lists are built from scratch) with LC_HOT_GONE: it has no
 * partners. */
LC_INLINE int hot_may_pair(const lc_hot *a, const lc_hot *b)
{
    return !((a->flags | b->flags) & LC_HOT_GONE) && !(a->flags & b->flags & LC_SLOT_STATIC) &&
           (a->cat & b->mask) && (b->cat & a->mask) && !(a->group == b->group && a->group != 0);
}

locd_status lc_adj_build(locd_scene *s)
{
    const locd_allocator *a = s->alloc;
    const size_t n = s->ndense, heads = s->hot_cap;
    const uint32_t *p;
    float *fb = NULL;
    size_t k, np, total = 0;
    locd_stats st_find;
    locd_status st;
    lc_adj_drop(s);
    if (heads > LC_ADJ_INDEX) /* an entry keeps one bit for PAIRED */
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "too many objects for partner lists");
    s->adj = lc_alloc(a, heads * sizeof *s->adj);
    fb = lc_alloc(a, (n ? n : 1) * 6 * sizeof *fb);
    if (!s->adj || !fb)
        goto nomem;
    s->adj_heads = heads;
    memset(s->adj, 0, heads * sizeof *s->adj);
    /* The fat boxes in sweep units: integers below 2^21, floats exactly, so
       the engine's closed test on them is the packed boxes' test. */
    for (k = 0; k < n; k++) {
        const uint64_t *q = s->hq + LC_HQ * k;
        uint32_t ax;
        for (ax = 0; ax < 3; ax++) {
            fb[6 * k + ax] = (float)((q[0] >> (ax * LC_SBITS)) & LC_SMASK);
            fb[6 * k + 3 + ax] = (float)((q[1] >> (ax * LC_SBITS)) & LC_SMASK);
        }
    }
    memset(&st_find, 0, sizeof st_find);
    st_find.size = sizeof st_find;
    if ((st = s->engine->ops->find(s->engine, fb, n, 0, 0, &s->found, &st_find)) != LOCD_OK) {
        lc_free(a, fb, (n ? n : 1) * 6 * sizeof *fb);
        lc_adj_drop(s);
        return st;
    }
    lc_free(a, fb, (n ? n : 1) * 6 * sizeof *fb);
    fb = NULL;
    p = s->found.data, np = s->found.count;
    /* counts (in n), then runs with room, then the entries */
    for (k = 0; k < np; k++) {
        const uint32_t i = p[2 * k], j = p[2 * k + 1];
        if (hot_may_pair(&s->hot[i], &s->hot[j]))
            s->adj[i].n++, s->adj[j].n++;
    }
    for (k = 0; k < n; k++) {
        s->adj[k].off = (uint32_t)total;
        s->adj[k].cap = room_for(s->adj[k].n);
        total += s->adj[k].cap;
        s->adj_live += s->adj[k].n;
        s->adj[k].n = 0;
    }
    if (total > UINT32_MAX - (total >> 2) - 64)
        goto nomem;
    s->adj_cap = total + (total >> 3) + 64;
    if (!(s->adj_pool = lc_alloc(a, s->adj_cap * sizeof *s->adj_pool)))
        goto nomem;
    s->adj_used = total;
    for (k = 0; k < np; k++) {
        const uint32_t i = p[2 * k], j = p[2 * k + 1];
        if (hot_may_pair(&s->hot[i], &s->hot[j])) {
            const uint32_t paired = lc_hot_meet(s, &s->hot[i], &s->hot[j]) ? LC_ADJ_PAIRED : 0u;
            s->adj_pool[s->adj[i].off + s->adj[i].n++] = j | paired;
            s->adj_pool[s->adj[j].off + s->adj[j].n++] = i | paired;
        }
    }
    s->have_adj = 1;
    return LOCD_OK;
nomem:
    lc_free(a, fb, (n ? n : 1) * 6 * sizeof *fb);
    lc_adj_drop(s);
    return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the partner lists");
}

void lc_adj_unlink(locd_scene *s, uint32_t d)
{
    lc_adj *h = &s->adj[d];
    uint32_t k;
    for (k = 0; k < h->n; k++) {
        lc_adj *ho = &s->adj[s->adj_pool[h->off + k] & LC_ADJ_INDEX];
        uint32_t *v = s->adj_pool + ho->off, x;
        for (x = 0; x < ho->n; x++)
            if ((v[x] & LC_ADJ_INDEX) == d) {
                v[x] = v[--ho->n];
                break;
            }
    }
    s->adj_live -= 2 * (size_t)h->n;
    h->n = 0;
}

/* Room for `need` more pool entries at its end: the pool packed into a new
 * one (each list with room) when it is full. 0 on no memory. */
static int pool_room(locd_scene *s, size_t need)
{
    size_t k, total = 0, cap;
    uint32_t *pool;
    if (s->adj_used + need <= s->adj_cap)
        return 1;
    for (k = 0; k < s->adj_heads; k++)
        total += s->adj[k].n ? room_for(s->adj[k].n) : 0;
    cap = total + need;
    cap += cap / 2 + 64;
    if (cap > UINT32_MAX || !(pool = lc_alloc(s->alloc, cap * sizeof *pool)))
        return 0;
    total = 0;
    for (k = 0; k < s->adj_heads; k++) {
        lc_adj *h = &s->adj[k];
        if (!h->n) {
            h->off = 0, h->cap = 0;
            continue;
        }
        memcpy(pool + total, s->adj_pool + h->off, h->n * sizeof *pool);
        h->off = (uint32_t)total, h->cap = room_for(h->n);
        total += h->cap;
    }
    lc_free(s->alloc, s->adj_pool, s->adj_cap * sizeof *s->adj_pool);
    s->adj_pool = pool, s->adj_cap = cap, s->adj_used = total;
    return 1;
}

/* Appends b to a's list, moving the list to the pool's end when full. */
static int push(locd_scene *s, uint32_t a, uint32_t b)
{
    lc_adj *h = &s->adj[a];
    if (h->n == h->cap) {
        const uint32_t cap = 2 * h->cap + 4;
        if (!pool_room(s, cap))
            return 0;
        h = &s->adj[a];
        memcpy(s->adj_pool + s->adj_used, s->adj_pool + h->off, h->n * sizeof *s->adj_pool);
        h->off = (uint32_t)s->adj_used, h->cap = cap;
        s->adj_used += cap;
    }
    s->adj_pool[h->off + h->n++] = b;
    return 1;
}

void lc_adj_link(locd_scene *s, uint32_t a, uint32_t b, int paired)
{
    const uint32_t bit = paired ? LC_ADJ_PAIRED : 0u;
    if (!s->have_adj)
        return;
    if (!push(s, a, b | bit) || !push(s, b, a | bit)) {
        lc_adj_drop(s); /* the scene searches every moved object until the lists are built again */
        return;
    }
    s->adj_live += 2;
}

void lc_adj_set_paired(locd_scene *s, uint32_t a, uint32_t k, uint32_t b, int paired)
{
    const lc_adj *hb = &s->adj[b];
    uint32_t *v = s->adj_pool + hb->off, x;
    uint32_t *e = s->adj_pool + s->adj[a].off + k;
    *e = (*e & LC_ADJ_INDEX) | (paired ? LC_ADJ_PAIRED : 0u);
    for (x = 0; x < hb->n; x++)
        if ((v[x] & LC_ADJ_INDEX) == a) {
            v[x] = a | (paired ? LC_ADJ_PAIRED : 0u);
            break;
        }
}
