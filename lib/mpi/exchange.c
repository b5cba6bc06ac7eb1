/* The all-to-all exchange of the distributed strategy.
 *
 * An entry goes to the rank whose key range holds its key (its owner) and,
 * replicated, to every later rank whose range starts inside the entry's
 * cell: a cell's subtree is one interval of keys in pre-order, so those
 * are exactly the ranks that may sweep a descendant of the cell and need
 * the cell on their stack (docs/cluster.md). With each entry go the boxes
 * it names, once per destination, and their global indices.
 *
 * The entries go first (natives straight from the sorted array, the few
 * replicas from a buffer of their own), are sorted on arrival, and only
 * then the boxes, each destination's packed just before its round: a
 * rank never holds its entries or its boxes twice over at once (the peak
 * memory of docs/cluster.md).
 *
 * Indices: what a rank receives from rank s names s's boxes by their
 * position among the boxes s sent it, ascending; the receiver adds where
 * s's boxes start in its receive buffer. Sources are in rank order and
 * each sends its boxes ascending, so local indices ascend with global
 * ones: the order of the entries within a cell, and i < j, are kept. */
#include "mpi/part.h"

#include <stdlib.h>

/* Whether rank r (after the owner) gets a copy of a cell whose subtree
 * ends at key `last`: its range starts inside the subtree and is not empty. */
static int replica_to(const uint64_t *split, int r, uint64_t last)
{
    return split[r] <= last && split[r] < split[r + 1];
}

/* Where one rank's outgoing data go, and what it receives, per rank. */
typedef struct lm_plan {
    size_t *nat_begin, *nat_end;  /* native entries for rank r: ent[nat_begin[r], nat_end[r]) */
    uint64_t *rep_cnt, *rep_dis;  /* replicated entries for rank r: rep[rep_dis[r], + rep_cnt[r]) */
    uint64_t *ocnt;               /* boxes sent to rank r */
    uint64_t *r_rep, *r_nat, *r_obj; /* received from rank s */
    uint64_t *r_edis, *r_odis;    /* where source s's entries and boxes start (ranks + 1) */
    uint64_t *bits;               /* ranks bitmaps of this rank's boxes: which go to rank r */
    uint32_t *before;             /* per bitmap word: boxes set before it */
    size_t words;
} lm_plan;

static void plan_free(lm_plan *p)
{
    free(p->nat_begin);
    free(p->bits);
    free(p->before);
    memset(p, 0, sizeof *p);
}

static int plan_alloc(lm_plan *p, int ranks, size_t local_n)
{
    const size_t k = (size_t)ranks + 1;
    char *all = calloc(1, 2 * k * sizeof(size_t) + 9 * k * sizeof(uint64_t));
    memset(p, 0, sizeof *p);
    if (!all)
        return 0;
    p->nat_begin = (size_t *)(void *)all;
    p->nat_end = p->nat_begin + k;
    p->rep_cnt = (uint64_t *)(void *)(all + 2 * k * sizeof(size_t));
    p->rep_dis = p->rep_cnt + k;
    p->ocnt = p->rep_cnt + 2 * k;
    p->r_rep = p->rep_cnt + 3 * k;
    p->r_nat = p->rep_cnt + 4 * k;
    p->r_obj = p->rep_cnt + 5 * k;
    p->r_edis = p->rep_cnt + 6 * k;
    p->r_odis = p->rep_cnt + 7 * k;
    /* one bitmap per rank: local_n / 8 bytes each, far below the entries */
    p->words = local_n / 64 + 1;
    p->bits = calloc((size_t)ranks * p->words, sizeof *p->bits);
    p->before = malloc((size_t)ranks * p->words * sizeof *p->before);
    return p->bits && p->before;
}

/* Native ranges (owner's) and the replicas (later ranks whose range starts
 * inside the entry's cell), in key order per destination. */
static locd_status route(const lm_ctx *c, const uint64_t *split, lm_plan *p, uint64_t **rep)
{
    const uint32_t ib = c->grid.index_bits, depth = c->grid.depth;
    size_t i;
    int owner = 0, r, pass;
    for (r = 0; r < c->ranks; r++) {
        p->nat_begin[r] = lc_lower_bound_inline(c->ent, c->nent, split[r] << ib);
        p->nat_end[r] = r + 1 < c->ranks ? lc_lower_bound_inline(c->ent, c->nent, split[r + 1] << ib) : c->nent;
    }
    *rep = NULL;
    for (pass = 0; pass < 2; pass++) { /* count, then fill */
        if (pass == 1) {
            p->rep_dis[0] = 0;
            for (r = 0; r < c->ranks; r++)
                p->rep_dis[r + 1] = p->rep_dis[r] + p->rep_cnt[r];
            *rep = malloc(p->rep_dis[c->ranks] * sizeof **rep + 1);
            if (!*rep)
                return lc_error(LOCD_ERR_NO_MEMORY, "%llu replicated entries",
                                (unsigned long long)p->rep_dis[c->ranks]);
            for (r = 0; r < c->ranks; r++)
                p->rep_cnt[r] = 0;
        }
        owner = 0;
        for (i = 0; i < c->nent; i++) {
            const uint64_t key = c->ent[i] >> ib, last = lm_key_last(key, depth);
            while (owner + 1 < c->ranks && split[owner + 1] <= key)
                owner++;
            for (r = owner + 1; r < c->ranks && split[r] <= last; r++) {
                if (!replica_to(split, r, last))
                    continue;
                if (pass == 1)
                    (*rep)[p->rep_dis[r] + p->rep_cnt[r]] = c->ent[i];
                p->rep_cnt[r]++;
            }
        }
    }
    return LOCD_OK;
}

/* Marks rank r's boxes in its bitmap; returns how many. */
static uint64_t mark(lm_plan *p, int r, const uint64_t *e, size_t n, uint64_t imask)
{
    uint64_t *bits = p->bits + (size_t)r * p->words, total = 0;
    uint32_t *before = p->before + (size_t)r * p->words;
    size_t i;
    for (i = 0; i < n; i++) {
        const uint64_t o = e[i] & imask;
        bits[o >> 6] |= 1ull << (o & 63);
    }
    for (i = 0; i < p->words; i++) {
        before[i] = (uint32_t)total;
        total += (uint64_t)__builtin_popcountll(bits[i]);
    }
    return total;
}

/* Entries name rank r's boxes by their position among them. */
static void renumber(const lm_plan *p, int r, uint64_t *e, size_t n, uint64_t imask)
{
    const uint64_t *bits = p->bits + (size_t)r * p->words;
    const uint32_t *before = p->before + (size_t)r * p->words;
    size_t i;
    for (i = 0; i < n; i++) {
        const uint64_t o = e[i] & imask, below = bits[o >> 6] & ((1ull << (o & 63)) - 1);
        e[i] = (e[i] & ~imask) | (before[o >> 6] + (uint64_t)__builtin_popcountll(below));
    }
}

/* Rank r's boxes, ascending, and their global indices. */
static void pack(const lm_ctx *c, const lm_plan *p, int r, char *box, uint32_t *idx)
{
    const uint64_t *bits = p->bits + (size_t)r * p->words;
    size_t i, w = 0;
    for (i = 0; i < p->words; i++) {
        uint64_t m = bits[i];
        while (m) {
            const size_t o = 64 * i + (size_t)__builtin_ctzll(m);
            if (c->f64) /* constant sizes: the copies inline */
                memcpy(box + w * c->es, (const double *)c->boxes + 6 * o, 6 * sizeof(double));
            else
                memcpy(box + w * c->es, (const float *)c->boxes + 6 * o, 6 * sizeof(float));
            idx[w++] = (uint32_t)(c->offsets[c->rank] + o);
            m &= m - 1;
        }
    }
}

/* Entries, round by round: the replicas then the natives of each source,
 * back to back at r_edis[source]. */
static void send_entries(lm_ctx *c, const lm_plan *p, const uint64_t *rep, uint64_t *recv)
{
    int step;
    for (step = 0; step < c->ranks; step++) {
        const int to = (c->rank + step) % c->ranks, from = (c->rank - step + c->ranks) % c->ranks;
        const uint64_t *nat = c->ent + p->nat_begin[to];
        const uint64_t nnat = p->nat_end[to] - p->nat_begin[to];
        if (step == 0) {
            memcpy(recv + p->r_edis[from], rep + p->rep_dis[to], p->rep_cnt[to] * sizeof *recv);
            memcpy(recv + p->r_edis[from] + p->rep_cnt[to], nat, nnat * sizeof *recv);
            continue;
        }
        lm_sendrecv(c, to, rep + p->rep_dis[to], p->rep_cnt[to], from, recv + p->r_edis[from], p->r_rep[from],
                    MPI_UINT64_T, sizeof *recv);
        lm_sendrecv(c, to, nat, nnat, from, recv + p->r_edis[from] + p->r_rep[from], p->r_nat[from], MPI_UINT64_T,
                    sizeof *recv);
    }
}

/* Boxes and indices, round by round, each packed just before it is sent
 * (one destination's worth of memory at a time). */
static locd_status send_boxes(lm_ctx *c, const lm_plan *p, lm_held *h, MPI_Datatype box_type)
{
    uint64_t most = 0;
    char *tbox;
    uint32_t *tidx;
    int step, r;
    for (r = 0; r < c->ranks; r++)
        if (r != c->rank && p->ocnt[r] > most)
            most = p->ocnt[r];
    tbox = malloc(most * c->es + 1);
    tidx = malloc(most * sizeof *tidx + 1);
    if (lm_agree(c, (!tbox || !tidx) ? lc_error(LOCD_ERR_NO_MEMORY, "%llu boxes to send", (unsigned long long)most)
                                     : LOCD_OK) != LOCD_OK) {
        free(tbox);
        free(tidx);
        return LOCD_ERR_NO_MEMORY;
    }
    for (step = 0; step < c->ranks; step++) {
        const int to = (c->rank + step) % c->ranks, from = (c->rank - step + c->ranks) % c->ranks;
        char *rbox = (char *)h->boxes + p->r_odis[from] * c->es;
        uint32_t *ridx = h->gidx + p->r_odis[from];
        if (step == 0) {
            pack(c, p, to, rbox, ridx);
            continue;
        }
        pack(c, p, to, tbox, tidx);
        lm_sendrecv(c, to, tbox, p->ocnt[to], from, rbox, p->r_obj[from], box_type, c->es);
        lm_sendrecv(c, to, tidx, p->ocnt[to], from, ridx, p->r_obj[from], MPI_UINT32_T, sizeof *ridx);
    }
    free(tbox);
    free(tidx);
    return LOCD_OK;
}

/* The receiver's renumbering (see the top of the file), then the sort. */
static locd_status settle(lm_ctx *c, const lm_plan *p, lm_held *h, const uint64_t *split)
{
    uint64_t *scratch;
    locd_status st;
    int s;
    for (s = 0; s < c->ranks; s++) {
        uint64_t i;
        for (i = p->r_edis[s]; i < p->r_edis[s + 1]; i++)
            h->ent[i] += p->r_odis[s];
    }
    scratch = malloc(h->count * sizeof *scratch + 1);
    if (!scratch)
        return lc_error(LOCD_ERR_NO_MEMORY, "%zu entries of sort scratch", h->count);
    st = locd_sort_entries(&c->grid, h->ent, scratch, h->count);
    free(scratch);
    if (st)
        return st;
    h->begin = lc_lower_bound_inline(h->ent, h->count, split[c->rank] << c->grid.index_bits);
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

/* Marks, counts and renumbers what goes where (this rank's side). */
static locd_status prepare(lm_ctx *c, const uint64_t *split, lm_plan *p, uint64_t **rep)
{
    const uint64_t imask = (1ull << c->grid.index_bits) - 1;
    locd_status st;
    int r;
    if (!plan_alloc(p, c->ranks, c->local_n))
        return lc_error(LOCD_ERR_NO_MEMORY, "exchange plan of %d ranks", c->ranks);
    if ((st = route(c, split, p, rep)) != LOCD_OK)
        return st;
    for (r = 0; r < c->ranks; r++) { /* mark every destination before renumbering any */
        mark(p, r, c->ent + p->nat_begin[r], p->nat_end[r] - p->nat_begin[r], imask);
        p->ocnt[r] = mark(p, r, *rep + p->rep_dis[r], p->rep_cnt[r], imask);
    }
    for (r = 0; r < c->ranks; r++) {
        renumber(p, r, c->ent + p->nat_begin[r], p->nat_end[r] - p->nat_begin[r], imask);
        renumber(p, r, *rep + p->rep_dis[r], p->rep_cnt[r], imask);
    }
    return LOCD_OK;
}

/* Counts both ways; every rank learns what it receives from every other. */
static void exchange_counts(lm_ctx *c, lm_plan *p, uint64_t *counts)
{
    int r;
    for (r = 0; r < c->ranks; r++) {
        counts[3 * r] = p->rep_cnt[r];
        counts[3 * r + 1] = p->nat_end[r] - p->nat_begin[r];
        counts[3 * r + 2] = p->ocnt[r];
    }
    MPI_Alltoall(counts, 3, MPI_UINT64_T, counts + 3 * c->ranks, 3, MPI_UINT64_T, c->comm);
    p->r_edis[0] = p->r_odis[0] = 0;
    for (r = 0; r < c->ranks; r++) {
        p->r_rep[r] = counts[3 * c->ranks + 3 * r];
        p->r_nat[r] = counts[3 * c->ranks + 3 * r + 1];
        p->r_obj[r] = counts[3 * c->ranks + 3 * r + 2];
        p->r_edis[r + 1] = p->r_edis[r] + p->r_rep[r] + p->r_nat[r];
        p->r_odis[r + 1] = p->r_odis[r] + p->r_obj[r];
    }
}

locd_status lm_exchange(lm_ctx *c, const uint64_t *split, lm_held *h)
{
    lm_plan p;
    uint64_t *rep = NULL, *counts = NULL;
    MPI_Datatype box_type;
    locd_status st;
    memset(h, 0, sizeof *h);
    memset(&p, 0, sizeof p);
    if (c->ranks == 1)
        return keep_all(c, h);
    st = prepare(c, split, &p, &rep);
    counts = malloc(6 * (size_t)c->ranks * sizeof *counts);
    if (!st && !counts)
        st = lc_error(LOCD_ERR_NO_MEMORY, "exchange counts");
    if ((st = lm_agree(c, st)) != LOCD_OK)
        goto done;
    exchange_counts(c, &p, counts);
    /* Entries first, and sorted, while no box has been copied: the peak
       memory is then the entries twice or the boxes twice, not both. */
    h->count = (size_t)p.r_edis[c->ranks];
    h->nobj = (size_t)p.r_odis[c->ranks];
    h->ent = malloc(h->count * sizeof *h->ent + 1);
    if ((st = lm_agree(c, h->ent ? LOCD_OK : lc_error(LOCD_ERR_NO_MEMORY, "%zu entries to receive", h->count))) !=
        LOCD_OK)
        goto done;
    send_entries(c, &p, rep, h->ent);
    free(rep);
    rep = NULL;
    free(c->ent); /* sent: the boxes are read from the caller's array */
    c->ent = NULL;
    c->st.ms_exchange = lm_lap(c);
    if ((st = lm_agree(c, settle(c, &p, h, split))) != LOCD_OK)
        goto done;
    c->st.ms_merge = lm_lap(c);
    h->boxes = malloc(h->nobj * c->es + 1);
    h->gidx = malloc(h->nobj * sizeof *h->gidx + 1);
    st = (!h->boxes || !h->gidx) ? lc_error(LOCD_ERR_NO_MEMORY, "%zu boxes to receive", h->nobj) : LOCD_OK;
    if ((st = lm_agree(c, st)) != LOCD_OK)
        goto done;
    MPI_Type_contiguous((int)c->es, MPI_BYTE, &box_type);
    MPI_Type_commit(&box_type);
    st = send_boxes(c, &p, h, box_type);
    MPI_Type_free(&box_type);
    c->st.ms_exchange += lm_lap(c);
done:
    free(rep);
    free(counts);
    plan_free(&p);
    if (st)
        lm_held_free(h);
    return st;
}
