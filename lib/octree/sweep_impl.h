/* Step 4, the sweep's main loop for one input precision and kernel family.
 * Included by sweep.c (the include-template of octree.h) with LC_T (float
 * or double), LC_SUFFIX, LC_TARGET (a function attribute, or nothing),
 * LC_SCAN (the scan of one entry's candidates) and LC_SCAN_SETUP (what
 * LC_SCAN needs declared) defined, and optionally LC_QUANTIZE6 (a vector
 * quantization of one box). */

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

/* Starts loading the box of entry `ahead` (if it is before `limit`). */
LC_INLINE void LC_FN(prefetch_)(const locd_grid *g, const LC_T *boxes, const uint64_t *qbox,
                                const uint64_t *entries, size_t ahead, size_t limit)
{
    if (ahead < limit) {
        const size_t idx = (size_t)(entries[ahead] & ((1ull << g->index_bits) - 1));
        if (qbox) {
            __builtin_prefetch(qbox + 2 * idx); /* 16 bytes: one cache line */
        } else { /* a 24- or 48-byte box may straddle two cache lines */
            __builtin_prefetch(boxes + 6 * idx);
            __builtin_prefetch(boxes + 6 * idx + 5);
        }
    }
}

/* Loads the records of one cell's entries [p, q) at rows at.. of the
 * columns. A cell of LC_SLAB_MIN entries or more is ordered by the x slab
 * (1/LC_SLABS of the cell) where each box starts, then by object, and
 * slab[b] receives the first row of slab b: an entry then needs only the
 * rows from the slab where a box ending at its own start could begin (see
 * the main loop), not the whole cell. A smaller cell keeps entry order and
 * returns 0 (every row is a candidate). */
static LC_TARGET int LC_FN(load_cell_)(const locd_grid *g, const LC_T *boxes, const uint64_t *qbox,
                                      const uint64_t *entries, size_t p, size_t q, lc_sweep_out *o,
                                      size_t at, const lc_slabs *sl, size_t slab[LC_SLABS + 1], int64_t *ext,
                                      locd_status *st_out)
{
    const uint32_t ib = g->index_bits;
    const uint64_t imask = (1ull << ib) - 1;
    const size_t m = q - p;
    uint64_t *tag;
    int64_t wide = 0;
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
    if (m > o->group.cap && (st = lc_buf_reserve(o->alloc, &o->group, sizeof(uint64_t), m)) != LOCD_OK) {
        *st_out = st;
        return -1;
    }
    tag = (uint64_t *)o->group.data;
    for (b = 0; b <= LC_SLABS; b++)
        slab[b] = 0;
    for (i = 0; i < m; i++) {
        const uint32_t idx = (uint32_t)(entries[p + i] & imask);
        int32_t qb[8];
        LC_FN(qbox_of_)(g, boxes, qbox, idx, qb);
        b = slab_of(sl, qb[0]);
        slab[b + 1]++;
        tag[i] = ((uint64_t)b << 32) | idx;
        if ((int64_t)qb[3] - qb[0] > wide)
            wide = (int64_t)qb[3] - qb[0];
    }
    for (b = 0; b < LC_SLABS; b++)
        slab[b + 1] += slab[b];
    {
        size_t fill[LC_SLABS];
        for (b = 0; b < LC_SLABS; b++)
            fill[b] = at + slab[b];
        for (i = 0; i < m; i++) {
            const uint32_t idx = (uint32_t)tag[i];
            int32_t qb[8];
            LC_FN(qbox_of_)(g, boxes, qbox, idx, qb);
            cand_put(&c, fill[tag[i] >> 32]++, qb, idx);
        }
    }
    for (b = 0; b <= LC_SLABS; b++)
        slab[b] += at;
    *ext = wide;
    return 1;
}

static LC_TARGET locd_status LC_FN(sweep_range_)(const locd_grid *g, const LC_T *boxes, const uint64_t *qbox,
                                                    const uint64_t *entries, size_t count, size_t begin, size_t end,
                                                    lc_sweep_out *o)
{
    const uint32_t ib = g->index_bits, depth = g->depth;
    const uint64_t imask = (1ull << ib) - 1;
    LC_SCAN_SETUP
    lc_seg segs[LC_MAX_SEGS];
    uint32_t nseg = 0;
    size_t ncand = 0, p, pf, npairs = o->count;
    uint64_t candidates = 0, exact = 0;
    int64_t ext;
    size_t slab[LC_SLABS + 1];
    lc_slabs sl;
    lc_scan sc;
    locd_status st;

    begin = cell_start_from(entries, count, begin, ib);
    end = cell_start_from(entries, count, end, ib);
    if (begin >= end)
        return LOCD_OK;
    if ((st = cand_reserve(o, 0, 1024)) != LOCD_OK)
        return st;
    sc.boxes = boxes;
    sc.f64 = sizeof(LC_T) == sizeof(double);

    /* Rebuild the segment stack a serial sweep would hold at `begin` (a
       cell's first entry): the populated ancestors of that cell. */
    if (begin > 0) {
        const uint64_t key0 = entries[begin] >> ib, pm0 = key0 >> LC_LEVEL_BITS;
        const uint32_t L0 = (uint32_t)(key0 & ((1u << LC_LEVEL_BITS) - 1));
        int32_t q0[8], cell0[3];
        uint32_t l;
        LC_FN(qbox_of_)(g, boxes, qbox, (uint32_t)(entries[begin] & imask), q0);
        lc_cell_of(q0, pm0 >> (3u * (depth - L0)), LC_SBITS - L0, cell0);
        for (l = 0; l < L0; l++) {
            const uint32_t shift = 3u * (depth - l);
            const uint64_t pml = (pm0 >> shift) << shift, keyl = (pml << LC_LEVEL_BITS) | l;
            const size_t a = lc_lower_bound(entries, begin, keyl << ib);
            const size_t b = lc_lower_bound(entries, begin, (keyl << ib) + imask + 1);
            const int32_t cl[3] = {cell0[0] >> (L0 - l), cell0[1] >> (L0 - l), cell0[2] >> (L0 - l)};
            if (a >= b)
                continue;
            if ((st = push_filtered(g, o, segs, &nseg, &ncand, pml, l, cl, b - a)) != LOCD_OK)
                return st;
            slabs_of(&sl, cl[0], LC_SBITS - l);
            if (LC_FN(load_cell_)(g, boxes, qbox, entries, a, b, o, ncand, &sl, slab, &ext, &st) < 0)
                return st;
            ncand += b - a;
        }
    }

    /* One cell at a time: its entries are contiguous in the sorted array. */
    for (p = pf = begin; p < end;) {
        const uint64_t key = entries[p] >> ib, pm = key >> LC_LEVEL_BITS;
        const uint32_t L = (uint32_t)(key & ((1u << LC_LEVEL_BITS) - 1));
        size_t q = p + 1, m, own, win, first, t;
        int slabbed;
        int32_t me[8];

        while (q < end && (entries[q] >> ib) == key)
            q++;
        m = q - p;
        /* Keep the loads of the next LC_PREFETCH entries past this cell in
           flight: a dense cell reads all its boxes at once. */
        for (; pf < q + LC_PREFETCH && pf < end; pf++)
            LC_FN(prefetch_)(g, boxes, qbox, entries, pf, end);
        LC_FN(qbox_of_)(g, boxes, qbox, (uint32_t)(entries[p] & imask), me);
        sc.s = LC_SBITS - L;
        lc_cell_of(me, pm >> (3u * (depth - L)), sc.s, sc.cell);

        while (nseg) {
            const lc_seg *sg = &segs[nseg - 1];
            if (sg->level < L && (pm >> (3u * (depth - sg->level))) == sg->cm)
                break;
            ncand = sg->start;
            nseg--;
        }
        if (m == 1 && !(q < end && lc_descends(entries[q] >> ib, pm, L, depth))) {
            /* A lone entry with no descendants after it: a segment of its
               own would serve nobody else, so it meets the enclosing
               segment's records directly (those that miss its cell fail the
               canonical test, and the order is the filtered one's). */
            if ((st = open_parent(g, o, segs, &nseg, &ncand, pm, L, sc.cell)) != LOCD_OK)
                return st;
            first = nseg ? segs[nseg - 1].start : ncand;
            if (ncand > first) {
                const size_t need = npairs + (ncand - first) + LC_PAIR_SLACK;
                if (2 * need > o->pairs.cap && (st = pairs_reserve(o, 2 * need, npairs)) != LOCD_OK)
                    return st;
                cols_of(o, &sc.c);
                sc.lo[0] = me[0];
                sc.lo[1] = me[1];
                sc.lo[2] = me[2];
                sc.hi[0] = me[3];
                sc.hi[1] = me[4];
                sc.hi[2] = me[5];
                sc.idx = (uint32_t)(entries[p] & imask);
                candidates += ncand - first;
                npairs = LC_SCAN(&sc, first, ncand, (uint32_t *)o->pairs.data, npairs, &exact);
            }
            p = q;
            continue;
        }
        if ((st = open_segment(g, o, segs, &nseg, &ncand, pm, L, sc.cell, m)) != LOCD_OK)
            return st;
        first = segs[nseg - 1].start;
        own = ncand;
        cols_of(o, &sc.c);
        if (m == 1) { /* the common lone entry: its box is already loaded */
            cand_put(&sc.c, own, me, (uint32_t)(entries[p] & imask));
            slabbed = 0;
        } else {
            slabs_of(&sl, sc.cell[0], sc.s);
            if ((slabbed = LC_FN(load_cell_)(g, boxes, qbox, entries, p, q, o, own, &sl, slab, &ext, &st)) < 0)
                return st;
        }

        /* Entry own+t meets the ancestors' records that overlap the cell
           ([first, own)) and the cell's earlier rows from the slab where a
           box of x extent <= ext ending at its low x could start: rows of
           earlier slabs start before that point, so they miss it. */
        for (t = 0; t < m; t++) {
            const size_t r = own + t;
            size_t need;
            sc.lo[0] = sc.c.lo[0][r];
            sc.lo[1] = sc.c.lo[1][r];
            sc.lo[2] = sc.c.lo[2][r];
            sc.hi[0] = sc.c.hi[0][r];
            sc.hi[1] = sc.c.hi[1][r];
            sc.hi[2] = sc.c.hi[2][r];
            sc.idx = sc.c.idx[r];
            win = slabbed ? slab[slab_of(&sl, (int64_t)sc.lo[0] - ext)] : own;
            need = npairs + (own - first) + (r - win) + LC_PAIR_SLACK;
            if (2 * need > o->pairs.cap && (st = pairs_reserve(o, 2 * need, npairs)) != LOCD_OK)
                return st;
            candidates += (own - first) + (r - win);
            if (win == own) { /* one contiguous run of candidates */
                if (r > first)
                    npairs = LC_SCAN(&sc, first, r, (uint32_t *)o->pairs.data, npairs, &exact);
            } else {
                if (own > first)
                    npairs = LC_SCAN(&sc, first, own, (uint32_t *)o->pairs.data, npairs, &exact);
                npairs = LC_SCAN(&sc, win, r, (uint32_t *)o->pairs.data, npairs, &exact);
            }
        }
        ncand = own + m;
        p = q;
    }
    o->count = npairs;
    o->candidates += candidates;
    o->exact_tests += exact;
    return LOCD_OK;
}

#undef LC_T
#undef LC_SUFFIX
