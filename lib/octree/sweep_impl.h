/* Step 4, the sweep's main loop for one input precision and kernel family.
 * Included by sweep.c (the include-template of octree.h) with LC_T (float
 * or double), LC_SUFFIX, LC_TARGET (a function attribute, or nothing),
 * LC_SCAN (the scan of one entry's candidates, given the sweep's context),
 * LC_TIES_FLUSH (the test of the ties that scan leaves, ties_flush_avx2)
 * defined, and optionally LC_QUANTIZE6 (a vector quantization of one box).
 * The main loop, sweep_range_, walks the cells; sweep_cell_ handles one,
 * as a lone entry (sweep_lone_) or a segment of its own (sweep_dense_,
 * scan_cell_). */

/* The object's box in sweep coordinates (LC_SBITS bits): from encode's
 * packed array, or quantized again with the very same operations
 * (bit-identical: no FMA contraction, see meson.build). q has room for 8
 * values (a vector store). */
LC_TARGET LC_INLINE void LC_FN(qbox_of_)(const locd_grid *g, const LC_T *boxes, const uint64_t *qbox, uint32_t idx,
                                         int32_t q[8])
{
    if (qbox) {
        const uint64_t w0 = qbox[2 * (size_t)idx], w1 = qbox[2 * (size_t)idx + 1];
        q[0] = (int32_t)(w0 & LC_SMASK);
        q[1] = (int32_t)((w0 >> LC_SBITS) & LC_SMASK);
        q[2] = (int32_t)(w0 >> (2 * LC_SBITS));
        q[3] = (int32_t)(w1 & LC_SMASK);
        q[4] = (int32_t)((w1 >> LC_SBITS) & LC_SMASK);
        q[5] = (int32_t)(w1 >> (2 * LC_SBITS));
    } else {
#ifdef LC_QUANTIZE6
        LC_QUANTIZE6(g, boxes + 6 * (size_t)idx, q);
#else
        const LC_T *b = boxes + 6 * (size_t)idx;
        int a;
        for (a = 0; a < 3; a++) {
            q[a] = lc_quantize(g, a, (double)b[a]) >> LC_SDROP;
            q[a + 3] = lc_quantize(g, a, (double)b[a + 3]) >> LC_SDROP;
        }
#endif
    }
}

/* Starts loading the box of entry `ahead` (if it is before `limit`), and
 * with `ties` set its original box too. */
LC_INLINE void LC_FN(prefetch_)(const locd_grid *g, const LC_T *boxes, const uint64_t *qbox,
                                const uint64_t *entries, size_t ahead, size_t limit, int ties)
{
    if (ahead < limit) {
        const size_t idx = (size_t)(entries[ahead] & ((1ull << g->index_bits) - 1));
        if (qbox) {
            __builtin_prefetch(qbox + 2 * idx); /* 16 bytes: one cache line */
            if (ties) {
                __builtin_prefetch(boxes + 6 * idx);
                __builtin_prefetch(boxes + 6 * idx + 5);
            }
        } else { /* a 24- or 48-byte box may straddle two cache lines */
            __builtin_prefetch(boxes + 6 * idx);
            __builtin_prefetch(boxes + 6 * idx + 5);
        }
    }
}

/* Loads the records of one cell's entries [p, q) at rows at.. of the
 * columns. A cell of LC_SLAB_MIN entries or more is ordered by the bucket
 * (x slab, y slab: lc_slabs, made by slabs_of for this cell and m = q - p)
 * where each box starts, then by object, and slab[b] receives the first row
 * of bucket b (slab[nbuckets] the end): an entry then needs only the rows of
 * the buckets where a box overlapping it can start (see scan_cell_), not
 * the whole cell, and 1 is returned; ext[a] receives the largest extent on
 * axis a. A smaller cell keeps entry order and returns 0 (every row is a
 * candidate). A negative locd_status when the bucket buffer cannot grow
 * (raised). */
static LC_TARGET int LC_FN(load_cell_)(const locd_grid *g, const LC_T *boxes, const uint64_t *qbox,
                                      const uint64_t *entries, size_t p, size_t q, lc_sweep_out *o,
                                      size_t at, const lc_slabs *sl, size_t slab[LC_BUCKETS + 1], int64_t ext[2])
{
    const uint32_t ib = g->index_bits, nb = 1u << (sl->bits[0] + sl->bits[1]);
    const uint64_t imask = (1ull << ib) - 1;
    const size_t m = q - p;
    uint64_t *tag;
    int64_t wide = 0, tall = 0;
    lc_cols c;
    size_t i;
    uint32_t b;
    locd_status st;

    cols_of(o, &c);
    if (m < LC_SLAB_MIN) {
        for (i = 0; i < m; i++) {
            const uint32_t idx = (uint32_t)(entries[p + i] & imask);
            int32_t qb[8];
            LC_FN(qbox_of_)(g, boxes, qbox, idx, qb);
            cand_put(&c, at + i, qb, idx);
        }
        return 0;
    }
    if (m > o->group.cap && (st = lc_buf_reserve(o->alloc, &o->group, sizeof(uint64_t), m)) != LOCD_OK)
        return st;
    tag = (uint64_t *)o->group.data;
    for (b = 0; b <= nb; b++)
        slab[b] = 0;
    for (i = 0; i < m; i++) {
        const uint32_t idx = (uint32_t)(entries[p + i] & imask);
        int32_t qb[8];
        LC_FN(qbox_of_)(g, boxes, qbox, idx, qb);
        b = sl->bits[1] ? bucket_of(sl, slab_of(sl, 0, qb[0]), slab_of(sl, 1, qb[1])) : slab_of(sl, 0, qb[0]);
        slab[b + 1]++;
        tag[i] = ((uint64_t)b << 32) | idx;
        if ((int64_t)qb[3] - qb[0] > wide)
            wide = (int64_t)qb[3] - qb[0];
        if ((int64_t)qb[4] - qb[1] > tall)
            tall = (int64_t)qb[4] - qb[1];
    }
    for (b = 0; b < nb; b++)
        slab[b + 1] += slab[b];
    {
        size_t fill[LC_BUCKETS];
        for (b = 0; b < nb; b++)
            fill[b] = at + slab[b];
        for (i = 0; i < m; i++) {
            const uint32_t idx = (uint32_t)tag[i];
            int32_t qb[8];
            LC_FN(qbox_of_)(g, boxes, qbox, idx, qb);
            cand_put(&c, fill[tag[i] >> 32]++, qb, idx);
        }
    }
    for (b = 0; b <= nb; b++)
        slab[b] += at;
    ext[0] = wide;
    ext[1] = tall;
    return 1;
}

/* Rebuilds the segment stack a serial sweep would hold at `begin` (a
 * cell's first entry): the populated ancestors of that cell, each with its
 * own entries loaded. */
static LC_TARGET locd_status LC_FN(rebuild_stack_)(const lc_sweep_ctx *cx, lc_sweep_state *ss, const LC_T *boxes,
                                                    size_t begin)
{
    const uint32_t ib = cx->ib, depth = cx->depth;
    const uint64_t imask = (1ull << ib) - 1, key0 = cx->entries[begin] >> ib, pm0 = key0 >> LC_LEVEL_BITS;
    const uint32_t L0 = (uint32_t)(key0 & ((1u << LC_LEVEL_BITS) - 1));
    int32_t q0[8], cell0[3];
    uint32_t l;
    locd_status st;
    LC_FN(qbox_of_)(cx->g, boxes, cx->qbox, (uint32_t)(cx->entries[begin] & imask), q0);
    lc_cell_of(q0, pm0 >> (3u * (depth - L0)), LC_SBITS - L0, cell0);
    for (l = 0; l < L0; l++) {
        const uint32_t shift = 3u * (depth - l);
        const uint64_t pml = (pm0 >> shift) << shift, keyl = (pml << LC_LEVEL_BITS) | l;
        const size_t a = lc_lower_bound(cx->entries, begin, keyl << ib);
        const size_t b = lc_lower_bound(cx->entries, begin, (keyl << ib) + imask + 1);
        const int32_t cl[3] = {cell0[0] >> (L0 - l), cell0[1] >> (L0 - l), cell0[2] >> (L0 - l)};
        if (a >= b)
            continue;
        if ((st = push_filtered(cx->g, cx->o, ss->segs, &ss->nseg, &ss->ncand, pml, l, cl, b - a)) != LOCD_OK)
            return st;
        slabs_of(&ss->sl, cl, LC_SBITS - l, b - a);
        if ((st = LC_FN(load_cell_)(cx->g, boxes, cx->qbox, cx->entries, a, b, cx->o, ss->ncand, &ss->sl, ss->slab,
                                    ss->ext)) < 0)
            return st;
        ss->ncand += b - a;
    }
    return LOCD_OK;
}

/* Tests the entry in ss->sc against candidate rows [first, end) (room for
 * the pairs is reserved: reserve_pairs). The count of exact tests goes
 * through a local: a scan called through a pointer then takes only its
 * address, and *cx stays in registers. */
LC_TARGET LC_INLINE void LC_FN(scan_)(lc_sweep_ctx *cx, lc_sweep_state *ss, size_t first, size_t end)
{
    uint64_t exact = cx->exact;
    cx->npairs = LC_SCAN(cx, &ss->sc, first, end, (uint32_t *)cx->o->pairs.data, cx->npairs, &exact);
    cx->exact = exact;
}

/* A lone entry (box me, object idx) with no descendants after it: a
 * segment of its own would serve nobody else, so it meets the enclosing
 * segment's records directly (those that miss its cell fail the canonical
 * test, and the order is the filtered one's). */
LC_TARGET LC_INLINE locd_status LC_FN(sweep_lone_)(lc_sweep_ctx *cx, lc_sweep_state *ss, uint64_t pm, uint32_t level,
                                                   const int32_t me[8], uint32_t idx, int sibling_next)
{
    size_t first;
    locd_status st;
    /* A parent segment pays when a later cell under the same parent reads
       it too; for this entry alone, filtering the records costs what
       scanning them does. Same pairs either way (open_parent). */
    if (sibling_next && (st = open_parent(cx->g, cx->o, ss->segs, &ss->nseg, &ss->ncand, pm, level, ss->sc.cell)) != LOCD_OK)
        return st;
    first = ss->nseg ? ss->segs[ss->nseg - 1].start : ss->ncand;
    if (ss->ncand > first) {
        if ((st = reserve_pairs(cx, ss->ncand - first)) != LOCD_OK)
            return st;
        cols_of(cx->o, &ss->sc.c);
        entry_from_box(&ss->sc, me, idx);
        LC_FN(scan_)(cx, ss, first, ss->ncand);
    }
    return LOCD_OK;
}

/* Scans the ancestor records [first, own) that can meet the entry under
 * test: all of them, or (lc_anc on) the wide ones and the narrow ones that
 * start in [lo_x - ext, hi_x]. A narrow record j that overlaps the entry
 * ends at or after lo_x and is at most ext wide, so it starts at or after
 * lo_x - ext, and at or before hi_x; the slab map is monotone, so j lies in
 * the slabs of those two ends. Returns the candidates scanned. */
LC_TARGET LC_INLINE size_t LC_FN(scan_ancestors_)(lc_sweep_ctx *cx, lc_sweep_state *ss, size_t first, size_t own)
{
    const lc_anc *an = &ss->an;
    size_t a, e, n = 0;
    if (!an->on) {
        if (own > first)
            LC_FN(scan_)(cx, ss, first, own);
        return own - first;
    }
    a = an->start[slab_of(&an->sl, 0, (int64_t)ss->sc.lo[0] - an->ext)];
    e = an->start[slab_of(&an->sl, 0, ss->sc.hi[0]) + 1];
    if (a == an->narrow) /* the window starts at the first narrow row: one run */
        a = an->wide;
    else if (an->narrow > an->wide)
        LC_FN(scan_)(cx, ss, an->wide, an->narrow), n += an->narrow - an->wide;
    if (e > a)
        LC_FN(scan_)(cx, ss, a, e), n += e - a;
    return n;
}

/* Entry own+t meets the ancestors' records that overlap the cell ([first,
 * own)) and the cell's earlier rows that can overlap it. With bucket order
 * (slabbed 1), an earlier row j that overlaps entry r starts, on x, at or
 * after lo_x(r) - ext[0] (it ends at or after lo_x(r) and is at most ext[0]
 * wide), and on y between lo_y(r) - ext[1] and hi_y(r); the slab map is
 * monotone, so j's x slab lies in [bx0, sx] and its y slab in [by0, by1]
 * (sx: r's own x slab). Rows are ordered by (x slab, y slab, object), so
 * these are, for each x slab bx < sx, the buckets (bx, by0..by1), one
 * contiguous run, and for bx = sx the rows from bucket (sx, by0) up to r.
 * Each run is scanned (runs that touch are scanned as one). Without bucket
 * order (slabbed 0) every earlier row of the cell is a candidate. */
LC_TARGET LC_INLINE locd_status LC_FN(scan_cell_)(lc_sweep_ctx *cx, lc_sweep_state *ss, size_t first, size_t own,
                                                  size_t m, int slabbed)
{
    const lc_slabs *sl = &ss->sl;
    size_t t;
    locd_status st;
    for (t = 0; t < m; t++) {
        const size_t r = own + t;
        size_t win;
        uint32_t bx, bx0, sx, by0, by1;
        if (cx->o->stop && t % LC_SWEEP_POLL == LC_SWEEP_POLL - 1 && __atomic_load_n(cx->o->stop, __ATOMIC_RELAXED))
            return LOCD_ERR_CANCELLED; /* a dense cell may be seconds of work */
        entry_from_row(&ss->sc, r);
        if (!slabbed) { /* one contiguous run of candidates */
            if ((st = reserve_pairs(cx, r - first)) != LOCD_OK)
                return st;
            if (r > first)
                LC_FN(scan_)(cx, ss, first, r);
            continue;
        }
        bx0 = slab_of(sl, 0, (int64_t)ss->sc.lo[0] - ss->ext[0]);
        win = ss->slab[bucket_of(sl, bx0, 0)]; /* the x window's first row */
        /* At most the ancestors and the x window: room for that many pairs. */
        if ((st = reserve_room(cx, (own - first) + (r - win))) != LOCD_OK)
            return st;
        cx->candidates += LC_FN(scan_ancestors_)(cx, ss, first, own);
        if (!sl->bits[1]) { /* one y slab: the x window is one run */
            cx->candidates += r - win;
            if (r > win)
                LC_FN(scan_)(cx, ss, win, r);
            continue;
        }
        sx = slab_of(sl, 0, ss->sc.lo[0]);
        by0 = slab_of(sl, 1, (int64_t)ss->sc.lo[1] - ss->ext[1]);
        by1 = slab_of(sl, 1, ss->sc.hi[1]);
        {
            size_t a = ss->slab[bucket_of(sl, bx0, by0)], e = a;
            for (bx = bx0; bx <= sx; bx++) {
                const size_t ra = ss->slab[bucket_of(sl, bx, by0)];
                const size_t re = bx < sx ? ss->slab[bucket_of(sl, bx, by1) + 1] : r;
                if (ra != e) { /* a gap: scan the run so far */
                    if (e > a) {
                        cx->candidates += e - a;
                        LC_FN(scan_)(cx, ss, a, e);
                    }
                    a = ra;
                }
                e = re;
            }
            if (e > a) {
                cx->candidates += e - a;
                LC_FN(scan_)(cx, ss, a, e);
            }
        }
    }
    return LOCD_OK;
}

/* Opens the segment of the cell of entries [p, q) (box me: the first
 * entry's) and loads the cell's own records after it, then tests them. */
LC_TARGET LC_INLINE locd_status LC_FN(sweep_dense_)(lc_sweep_ctx *cx, lc_sweep_state *ss, const LC_T *boxes, size_t p,
                                                    size_t q, uint64_t pm, uint32_t level, const int32_t me[8])
{
    const size_t m = q - p;
    size_t first, own;
    int slabbed = 0;
    locd_status st = open_segment(cx->g, cx->o, ss->segs, &ss->nseg, &ss->ncand, pm, level, ss->sc.cell, m);
    if (st)
        return st;
    first = ss->segs[ss->nseg - 1].start;
    own = ss->ncand;
    cols_of(cx->o, &ss->sc.c);
    if (m == 1) { /* the common lone entry: its box is already loaded */
        cand_put(&ss->sc.c, own, me, (uint32_t)(cx->entries[p] & ((1ull << cx->ib) - 1)));
    } else {
        slabs_of(&ss->sl, ss->sc.cell, ss->sc.s, m);
        slabbed = LC_FN(load_cell_)(cx->g, boxes, cx->qbox, cx->entries, p, q, cx->o, own, &ss->sl, ss->slab,
                                    ss->ext);
        if (slabbed < 0)
            return slabbed;
        if (slabbed && m >= LC_ANC_OWN_MIN && own - first >= LC_ANC_MIN) {
            if ((st = anc_order(cx->o, &ss->an, ss->sc.cell, ss->sc.s, first, own, own + m)) != LOCD_OK)
                return st;
            cols_of(cx->o, &ss->sc.c); /* the columns may have moved */
        }
    }
    st = LC_FN(scan_cell_)(cx, ss, first, own, m, slabbed);
    ss->an.on = 0; /* the copy past the cell's rows is dropped with it */
    if (st != LOCD_OK)
        return st;
    ss->ncand = own + m;
    return LOCD_OK;
}

/* One cell: entries [p, q) of the sorted array, which share its key. */
LC_TARGET LC_INLINE locd_status LC_FN(sweep_cell_)(lc_sweep_ctx *cx, lc_sweep_state *ss, const LC_T *boxes, size_t p,
                                                   size_t q, size_t end)
{
    const uint32_t ib = cx->ib, depth = cx->depth;
    const uint64_t key = cx->entries[p] >> ib, pm = key >> LC_LEVEL_BITS;
    const uint32_t level = (uint32_t)(key & ((1u << LC_LEVEL_BITS) - 1));
    const uint32_t idx = (uint32_t)(cx->entries[p] & ((1ull << ib) - 1));
    int32_t me[8];
    LC_FN(qbox_of_)(cx->g, boxes, cx->qbox, idx, me);
    ss->sc.s = LC_SBITS - level;
    lc_cell_of(me, pm >> (3u * (depth - level)), ss->sc.s, ss->sc.cell);
    pop_to_ancestors(ss, pm, level, depth);
    if (q - p == 1 && !(q < end && lc_descends(cx->entries[q] >> ib, pm, level, depth)))
        return LC_FN(sweep_lone_)(cx, ss, pm, level, me, idx,
                                  level > 0 && q < end && lc_descends(cx->entries[q] >> ib, pm, level - 1, depth));
    return LC_FN(sweep_dense_)(cx, ss, boxes, p, q, pm, level, me);
}

static LC_TARGET locd_status LC_FN(sweep_range_)(const locd_grid *g, const LC_T *boxes, const uint64_t *qbox,
                                                 const uint64_t *entries, size_t count, size_t begin, size_t end,
                                                 lc_sweep_out *o)
{
    const uint32_t ib = g->index_bits;
    lc_sweep_ctx cx;
    lc_sweep_state ss;
    size_t p, pf, cells = 0;
    locd_status st;

    begin = cell_start_from(entries, count, begin, ib);
    end = cell_start_from(entries, count, end, ib);
    if (begin >= end)
        return LOCD_OK;
    if ((st = cand_reserve(o, 0, 1024)) != LOCD_OK)
        return st;
    sweep_ctx_init(&cx, &ss, g, boxes, sizeof(LC_T) == sizeof(double), qbox, entries, o);
    if (begin > 0 && (st = LC_FN(rebuild_stack_)(&cx, &ss, boxes, begin)) != LOCD_OK)
        return st;
    /* One cell at a time: its entries are contiguous in the sorted array. */
    for (p = pf = begin; p < end; cells++) {
        const size_t q = cell_end(entries, p, end, ib);
        if (o->stop && cells % LC_SWEEP_POLL == LC_SWEEP_POLL - 1 && __atomic_load_n(o->stop, __ATOMIC_RELAXED))
            return LOCD_ERR_CANCELLED;
        /* Ties are common once those tested so far (counted at each flush)
           are more than a quarter of the entries, as on a triangle mesh. */
        ss.ties.common = cx.exact * 4 > p - begin;
        /* Keep the loads of the next LC_PREFETCH entries past this cell in
           flight: a dense cell reads all its boxes at once. Their original
           boxes too where ties are common: a tie's test reads both objects'
           boxes. Where almost nothing ties (the generated 10^6 scenes) those
           loads took the bandwidth the packed boxes need, 15-37% slower
           (bench/results/kernels_notes.md). */
        for (; pf < q + LC_PREFETCH && pf < end; pf++)
            LC_FN(prefetch_)(g, boxes, qbox, entries, pf, end, ss.ties.common);
        if ((st = LC_FN(sweep_cell_)(&cx, &ss, boxes, p, q, end)) != LOCD_OK)
            return st;
        p = q;
    }
    cx.npairs = LC_TIES_FLUSH(&ss.ties, boxes, sizeof(LC_T) == sizeof(double), (uint32_t *)o->pairs.data, cx.npairs,
                           &cx.exact);
    o->count = cx.npairs;
    o->candidates += cx.candidates;
    o->exact_tests += cx.exact;
    return LOCD_OK;
}

#undef LC_T
#undef LC_SUFFIX
