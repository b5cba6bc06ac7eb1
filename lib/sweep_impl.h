/* Step 4, the sweep's main loop for one input precision. Included by
 * sweep.c with LC_T (float or double), LC_SUFFIX and LC_IS_F64 defined. */

#define LC_CAT2(a, b) a##b
#define LC_CAT(a, b) LC_CAT2(a, b)
#define LC_FN(name) LC_CAT(name, LC_SUFFIX)

/* The object's quantized box: from encode's array, or computed again with
 * the very same function (bit-identical: no FMA contraction, see meson.build). */
LC_INLINE void LC_FN(qbox_of_)(const locd_grid *g, const LC_T *boxes, const int32_t *qbox, uint32_t idx,
                               int32_t q[6])
{
    if (qbox) {
        memcpy(q, qbox + 6 * (size_t)idx, 6 * sizeof(int32_t));
    } else {
        const LC_T *b = boxes + 6 * (size_t)idx;
        int a;
        for (a = 0; a < 3; a++) {
            q[a] = lc_quantize(g, a, (double)b[a]);
            q[a + 3] = lc_quantize(g, a, (double)b[a + 3]);
        }
    }
}

locd_status LC_FN(lc_sweep_range_)(const locd_grid *g, const LC_T *boxes, const int32_t *qbox,
                                   const uint64_t *entries, size_t begin, size_t end, lc_sweep_out *o)
{
    const uint32_t ib = g->index_bits, depth = g->depth;
    const uint64_t imask = (1ull << ib) - 1;
    const lc_scan_fn scan = pick_scan();
    lc_seg segs[LC_MAX_SEGS];
    uint32_t nseg = 0;
    size_t ncand = 0, p, npairs = o->count;
    uint64_t candidates = 0, exact = 0;
    lc_scan sc;
    locd_status st;

    if (begin >= end)
        return LOCD_OK;
    if ((st = cand_reserve(o, 0, 1024)) != LOCD_OK)
        return st;
    sc.boxes = boxes;
    sc.f64 = sizeof(LC_T) == sizeof(double);

    /* Rebuild the segment stack a serial sweep would hold at `begin`: the
       populated ancestors of its cell, then its cell's earlier entries. */
    if (begin > 0) {
        const uint64_t key0 = entries[begin] >> ib, pm0 = key0 >> LC_LEVEL_BITS;
        const uint32_t L0 = (uint32_t)(key0 & ((1u << LC_LEVEL_BITS) - 1));
        int32_t q0[6], cell0[3];
        uint32_t l;
        LC_FN(qbox_of_)(g, boxes, qbox, (uint32_t)(entries[begin] & imask), q0);
        lc_cell_of(q0, pm0 >> (3u * (depth - L0)), LC_QBITS - L0, cell0);
        for (l = 0; l <= L0; l++) {
            const uint32_t shift = 3u * (depth - l);
            const uint64_t pml = (pm0 >> shift) << shift, keyl = (pml << LC_LEVEL_BITS) | l;
            const size_t a = lower_bound64(entries, begin, keyl << ib);
            const size_t b = lower_bound64(entries, begin, (keyl << ib) + imask + 1);
            const int32_t cl[3] = {cell0[0] >> (L0 - l), cell0[1] >> (L0 - l), cell0[2] >> (L0 - l)};
            size_t q;
            if (a >= b)
                continue;
            if ((st = push_filtered(g, o, segs, &nseg, &ncand, pml, l, cl, b - a)) != LOCD_OK)
                return st;
            cols_of(o, &sc.c);
            for (q = a; q < b; q++) {
                const uint32_t idx = (uint32_t)(entries[q] & imask);
                int32_t qb[6];
                LC_FN(qbox_of_)(g, boxes, qbox, idx, qb);
                cand_put(&sc.c, ncand++, qb, idx);
            }
        }
    }

    cols_of(o, &sc.c);
    for (p = begin; p < end; p++) {
        const uint64_t e = entries[p], key = e >> ib, pm = key >> LC_LEVEL_BITS;
        const uint32_t L = (uint32_t)(key & ((1u << LC_LEVEL_BITS) - 1));
        int32_t me[6];
        size_t first;

        if (p + LC_PREFETCH < end) {
            const size_t ahead = (size_t)(entries[p + LC_PREFETCH] & imask);
            if (qbox)
                __builtin_prefetch(qbox + 6 * ahead);
            else
                __builtin_prefetch(boxes + 6 * ahead);
        }
        sc.idx = (uint32_t)(e & imask);
        LC_FN(qbox_of_)(g, boxes, qbox, sc.idx, me);
        sc.s = LC_QBITS - L;
        lc_cell_of(me, pm >> (3u * (depth - L)), sc.s, sc.cell);

        while (nseg) {
            const lc_seg *sg = &segs[nseg - 1];
            if (sg->level <= L && (pm >> (3u * (depth - sg->level))) == sg->cm)
                break;
            ncand = sg->start;
            nseg--;
        }
        if (!nseg || segs[nseg - 1].level != L) {
            if ((st = open_segment(g, o, segs, &nseg, &ncand, pm, L, sc.cell, 1)) != LOCD_OK)
                return st;
            cols_of(o, &sc.c);
        } else if (ncand + 1 > o->cand_cap) {
            if ((st = cand_reserve(o, ncand, ncand + 1)) != LOCD_OK)
                return st;
            cols_of(o, &sc.c);
        }
        first = segs[nseg - 1].start;
        if (2 * (npairs + (ncand - first)) > o->pairs.cap) {
            if ((st = lc_buf_reserve(o->alloc, &o->pairs, sizeof(uint32_t), 2 * (npairs + (ncand - first)))) != LOCD_OK)
                return st;
        }
        candidates += ncand - first;
        sc.lo[0] = me[0];
        sc.lo[1] = me[1];
        sc.lo[2] = me[2];
        sc.hi[0] = me[3];
        sc.hi[1] = me[4];
        sc.hi[2] = me[5];
        if (ncand > first)
            npairs = scan(&sc, first, ncand, (uint32_t *)o->pairs.data, npairs, &exact);
        cand_put(&sc.c, ncand++, me, sc.idx);
    }
    o->count = npairs;
    o->candidates += candidates;
    o->exact_tests += exact;
    return LOCD_OK;
}

#undef LC_FN
#undef LC_CAT
#undef LC_CAT2
