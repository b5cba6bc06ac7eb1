/* The all-to-all exchange of the distributed strategy.
 *
 * An entry goes to the rank whose key range holds its key (its owner) and,
 * replicated, to every later rank whose range starts inside the entry's
 * cell: a cell's subtree is one interval of keys in pre-order, so those
 * are exactly the ranks that may sweep a descendant of the cell and need
 * the cell on their stack (docs/cluster.md). With each entry go the boxes
 * it names, once per destination, and their global indices.
 *
 * Indices: what a rank receives from rank s names s's boxes by their
 * position among the boxes s sent it, ascending; the receiver adds where
 * s's boxes start in its receive buffer. Sources are in rank order and
 * each sends its boxes ascending, so local indices ascend with global
 * ones: the order of the entries within a cell, and i < j, are kept. */
#include "mpi/part.h"

#include <stdlib.h>

/* Where one rank's outgoing entries go: counts and displacements per rank. */
typedef struct lm_plan {
    uint64_t *ecnt, *edis, *ocnt, *odis; /* entries and objects, sent */
    uint64_t *rcnt, *rdis, *rocnt, *rodis; /* received */
} lm_plan;

/* Whether rank r (after the owner) gets a copy of a cell whose subtree
 * ends at key `last`: its range starts inside the subtree and is not empty. */
static int replica_to(const uint64_t *split, int r, uint64_t last)
{
    return split[r] <= last && split[r] < split[r + 1];
}

/* The first position in sorted a[0, n) whose value is >= v (n if none). */
static size_t lower_bound(const uint64_t *a, size_t n, uint64_t v)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        const size_t mid = lo + (hi - lo) / 2;
        if (a[mid] < v)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

static void plan_free(lm_plan *p)
{
    free(p->ecnt);
}

static int plan_alloc(lm_plan *p, int ranks)
{
    uint64_t *all = calloc(8 * ((size_t)ranks + 1), sizeof *all);
    size_t k = (size_t)ranks + 1;
    if (!all)
        return 0;
    p->ecnt = all;
    p->edis = all + k;
    p->ocnt = all + 2 * k;
    p->odis = all + 3 * k;
    p->rcnt = all + 4 * k;
    p->rdis = all + 5 * k;
    p->rocnt = all + 6 * k;
    p->rodis = all + 7 * k;
    return 1;
}

static void prefix(const uint64_t *cnt, uint64_t *dis, int ranks)
{
    int r;
    dis[0] = 0;
    for (r = 0; r < ranks; r++)
        dis[r + 1] = dis[r] + cnt[r];
}

/* Fills send[] with each destination's entries, in key order (local indices). */
static void route(const lm_ctx *c, const uint64_t *split, lm_plan *p, uint64_t *send, int count_only)
{
    const uint32_t ib = c->grid.index_bits, depth = c->grid.depth;
    uint64_t *at = p->ocnt; /* fill cursor per rank (ocnt is free until the boxes are counted) */
    size_t i;
    int owner = 0, r;
    if (!count_only)
        for (r = 0; r < c->ranks; r++)
            at[r] = p->edis[r];
    for (i = 0; i < c->nent; i++) {
        const uint64_t key = c->ent[i] >> ib, last = lm_key_last(key, depth);
        while (owner + 1 < c->ranks && split[owner + 1] <= key)
            owner++;
        for (r = owner; r < c->ranks && (r == owner || split[r] <= last); r++) {
            if (r != owner && !replica_to(split, r, last))
                continue;
            if (count_only)
                p->ecnt[r]++;
            else
                send[at[r]++] = c->ent[i];
        }
    }
}

/* The boxes rank r's entries name: a bitmap of this rank's boxes, and the
 * boxes before each 64-box word, so that a box's position among them is a
 * prefix count plus a popcount. Returns how many. */
static uint64_t mark(const uint64_t *ent, size_t count, uint64_t imask, uint64_t *bits, uint32_t *before,
                     size_t words)
{
    size_t i;
    uint64_t total = 0;
    memset(bits, 0, words * sizeof *bits);
    for (i = 0; i < count; i++) {
        const uint64_t o = ent[i] & imask;
        bits[o >> 6] |= 1ull << (o & 63);
    }
    for (i = 0; i < words; i++) {
        before[i] = (uint32_t)total;
        total += (uint64_t)__builtin_popcountll(bits[i]);
    }
    return total;
}

/* Counts, then writes, each destination's boxes and global indices, and
 * renumbers its entries to positions among those boxes. */
static locd_status pack_boxes(lm_ctx *c, lm_plan *p, uint64_t *send, char **sbox, uint32_t **sidx)
{
    const uint64_t imask = (1ull << c->grid.index_bits) - 1;
    const size_t words = c->local_n / 64 + 1;
    uint64_t *bits = malloc(words * sizeof *bits);
    uint32_t *before = malloc(words * sizeof *before);
    int r;
    if (!bits || !before) {
        free(bits);
        free(before);
        return lc_error(LOCD_ERR_NO_MEMORY, "box bitmap of %zu words", words);
    }
    for (r = 0; r < c->ranks; r++)
        p->ocnt[r] = mark(send + p->edis[r], p->ecnt[r], imask, bits, before, words);
    prefix(p->ocnt, p->odis, c->ranks);
    *sbox = malloc(p->odis[c->ranks] * c->es + 1);
    *sidx = malloc(p->odis[c->ranks] * sizeof **sidx + 1);
    if (!*sbox || !*sidx) {
        free(bits);
        free(before);
        return lc_error(LOCD_ERR_NO_MEMORY, "%llu boxes to send", (unsigned long long)p->odis[c->ranks]);
    }
    for (r = 0; r < c->ranks; r++) {
        uint64_t *e = send + p->edis[r], w = p->odis[r];
        size_t i;
        mark(e, p->ecnt[r], imask, bits, before, words);
        for (i = 0; i < words; i++) {
            uint64_t m = bits[i];
            while (m) {
                const size_t o = 64 * i + (size_t)__builtin_ctzll(m);
                if (c->f64) /* constant sizes: the copies inline */
                    memcpy(*sbox + w * c->es, (const double *)c->boxes + 6 * o, 6 * sizeof(double));
                else
                    memcpy(*sbox + w * c->es, (const float *)c->boxes + 6 * o, 6 * sizeof(float));
                (*sidx)[w++] = (uint32_t)(c->offsets[c->rank] + o);
                m &= m - 1;
            }
        }
        for (i = 0; i < p->ecnt[r]; i++) {
            const uint64_t o = e[i] & imask;
            const uint64_t below = bits[o >> 6] & ((1ull << (o & 63)) - 1);
            e[i] = (e[i] & ~imask) | (before[o >> 6] + (uint64_t)__builtin_popcountll(below));
        }
    }
    free(bits);
    free(before);
    return LOCD_OK;
}

/* The receiver's renumbering (see the top of the file), then the sort. */
static locd_status settle(lm_ctx *c, lm_plan *p, lm_held *h, const uint64_t *split)
{
    uint64_t *scratch;
    locd_status st;
    int s;
    for (s = 0; s < c->ranks; s++) {
        uint64_t i;
        for (i = p->rdis[s]; i < p->rdis[s] + p->rcnt[s]; i++)
            h->ent[i] += p->rodis[s];
    }
    scratch = malloc(h->count * sizeof *scratch + 1);
    if (!scratch)
        return lc_error(LOCD_ERR_NO_MEMORY, "%zu entries of sort scratch", h->count);
    st = locd_sort_entries(&c->grid, h->ent, scratch, h->count);
    free(scratch);
    if (st)
        return st;
    h->begin = lower_bound(h->ent, h->count, split[c->rank] << c->grid.index_bits);
    return LOCD_OK;
}

/* One rank: its entries are the whole sorted scene already, its boxes the
 * whole scene in global order. Nothing moves. */
static locd_status keep_all(lm_ctx *c, lm_held *h)
{
    h->ent = c->ent;
    h->count = c->nent;
    h->begin = 0;
    h->boxes = (void *)(uintptr_t)c->boxes; /* only read; never freed (borrowed) */
    h->borrowed = 1;
    h->gidx = NULL;
    h->nobj = c->local_n;
    c->ent = NULL;
    return LOCD_OK;
}

locd_status lm_exchange(lm_ctx *c, const uint64_t *split, lm_held *h)
{
    lm_plan p;
    uint64_t *send = NULL, *counts = NULL;
    char *sbox = NULL;
    uint32_t *sidx = NULL;
    MPI_Datatype box_type;
    locd_status st = LOCD_OK;
    int r;
    memset(h, 0, sizeof *h);
    memset(&p, 0, sizeof p);
    if (c->ranks == 1)
        return keep_all(c, h);
    if (!plan_alloc(&p, c->ranks))
        st = lc_error(LOCD_ERR_NO_MEMORY, "exchange plan");
    if (!st) {
        route(c, split, &p, NULL, 1);
        prefix(p.ecnt, p.edis, c->ranks);
        send = malloc(p.edis[c->ranks] * sizeof *send + 1);
        if (!send)
            st = lc_error(LOCD_ERR_NO_MEMORY, "%llu entries to send", (unsigned long long)p.edis[c->ranks]);
    }
    if (!st) {
        route(c, split, &p, send, 0);
        free(c->ent); /* every entry is in send now */
        c->ent = NULL;
        st = pack_boxes(c, &p, send, &sbox, &sidx);
    }
    counts = malloc(4 * (size_t)c->ranks * sizeof *counts);
    if (!st && !counts)
        st = lc_error(LOCD_ERR_NO_MEMORY, "exchange counts");
    if ((st = lm_agree(c, st)) != LOCD_OK)
        goto done;
    for (r = 0; r < c->ranks; r++) {
        counts[2 * r] = p.ecnt[r];
        counts[2 * r + 1] = p.ocnt[r];
    }
    MPI_Alltoall(counts, 2, MPI_UINT64_T, counts + 2 * c->ranks, 2, MPI_UINT64_T, c->comm);
    for (r = 0; r < c->ranks; r++) {
        p.rcnt[r] = counts[2 * c->ranks + 2 * r];
        p.rocnt[r] = counts[2 * c->ranks + 2 * r + 1];
    }
    prefix(p.rcnt, p.rdis, c->ranks);
    prefix(p.rocnt, p.rodis, c->ranks);
    h->count = (size_t)p.rdis[c->ranks];
    h->nobj = (size_t)p.rodis[c->ranks];
    h->ent = malloc(h->count * sizeof *h->ent + 1);
    h->boxes = malloc(h->nobj * c->es + 1);
    h->gidx = malloc(h->nobj * sizeof *h->gidx + 1);
    st = (!h->ent || !h->boxes || !h->gidx) ? lc_error(LOCD_ERR_NO_MEMORY, "%zu entries and %zu boxes to receive",
                                                         h->count, h->nobj)
                                             : LOCD_OK;
    if ((st = lm_agree(c, st)) != LOCD_OK)
        goto done;
    MPI_Type_contiguous((int)c->es, MPI_BYTE, &box_type);
    MPI_Type_commit(&box_type);
    lm_alltoallv(c, send, p.ecnt, p.edis, h->ent, p.rcnt, p.rdis, MPI_UINT64_T, sizeof(uint64_t));
    free(send);
    send = NULL;
    lm_alltoallv(c, sbox, p.ocnt, p.odis, h->boxes, p.rocnt, p.rodis, box_type, c->es);
    lm_alltoallv(c, sidx, p.ocnt, p.odis, h->gidx, p.rocnt, p.rodis, MPI_UINT32_T, sizeof(uint32_t));
    MPI_Type_free(&box_type);
    free(sbox);
    free(sidx);
    sbox = NULL;
    sidx = NULL;
    c->st.ms_exchange = lm_lap(c);
    st = lm_agree(c, settle(c, &p, h, split));
    c->st.ms_merge = lm_lap(c);
done:
    free(send);
    free(sbox);
    free(sidx);
    free(counts);
    if (p.ecnt)
        plan_free(&p);
    if (st)
        lm_held_free(h);
    return st;
}
