/* Step 4, the sweep, for one input precision. Included by sweep.c with
 * LC_T (float or double) and LC_SUFFIX defined. See docs/encoding.md for why
 * each pair is reported exactly once. */

#define LC_CAT2(a, b) a##b
#define LC_CAT(a, b) LC_CAT2(a, b)
#define LC_FN(name) LC_CAT(name, LC_SUFFIX)

/* Exact closed-interval test on the caller's own coordinates. */
LC_INLINE int LC_FN(exact_overlap_)(const LC_T *a, const LC_T *b)
{
    return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

LC_INLINE void LC_FN(make_rec_)(const locd_grid *g, const LC_T *b, uint32_t idx, lc_rec *r)
{
    r->lo[0] = lc_quantize(g, 0, (double)b[0]);
    r->lo[1] = lc_quantize(g, 1, (double)b[1]);
    r->lo[2] = lc_quantize(g, 2, (double)b[2]);
    r->hi[0] = lc_quantize(g, 0, (double)b[3]);
    r->hi[1] = lc_quantize(g, 1, (double)b[4]);
    r->hi[2] = lc_quantize(g, 2, (double)b[5]);
    r->idx = idx;
    r->pad = 0;
}

locd_status LC_FN(lc_sweep_range_)(const locd_grid *g, const LC_T *boxes, const uint64_t *entries, size_t count,
                                   size_t begin, size_t end, lc_sweep_out *o)
{
    const uint32_t ib = g->index_bits, depth = g->depth;
    const uint64_t imask = (ib >= 64) ? ~0ull : ((1ull << ib) - 1);
    lc_seg segs[LC_MAX_SEGS];
    uint32_t nseg = 0;
    size_t ncand = 0, p, npairs = o->count;
    lc_rec *cand;
    uint32_t *pairs;
    uint64_t candidates = 0, exact = 0;
    locd_status st;

    (void)count; /* the state before `begin` only needs entries [0, begin) */
    if (begin >= end)
        return LOCD_OK;
    st = lc_buf_reserve(o->alloc, &o->cand, sizeof(lc_rec), 1024);
    if (st)
        return st;
    cand = (lc_rec *)o->cand.data;
    pairs = (uint32_t *)o->pairs.data;

    /* Rebuild the segment stack a serial sweep would hold at `begin`. */
    if (begin > 0) {
        uint64_t e0 = entries[begin], key0 = e0 >> ib, pm0 = key0 >> LC_LEVEL_BITS;
        uint32_t L0 = (uint32_t)(key0 & ((1u << LC_LEVEL_BITS) - 1)), l;
        for (l = 0; l <= L0; l++) {
            uint32_t shift = 3u * (depth - l);
            uint64_t pml = (pm0 >> shift) << shift;
            uint64_t keyl = (pml << LC_LEVEL_BITS) | l;
            size_t a = lc_lower_bound(entries, begin, keyl << ib);
            size_t b = lc_upper_bound(entries, begin, (keyl << ib) | imask);
            size_t q;
            if (a >= b)
                continue;
            st = lc_open_segment(g, o, &cand, segs, &nseg, &ncand, pml, l, (size_t)(b - a));
            if (st)
                return st;
            for (q = a; q < b; q++) {
                uint32_t idx = (uint32_t)(entries[q] & imask);
                LC_FN(make_rec_)(g, boxes + 6 * (size_t)idx, idx, &cand[ncand++]);
            }
        }
    }

    for (p = begin; p < end; p++) {
        const uint64_t e = entries[p], key = e >> ib, pm = key >> LC_LEVEL_BITS;
        const uint32_t L = (uint32_t)(key & ((1u << LC_LEVEL_BITS) - 1));
        const uint32_t idx = (uint32_t)(e & imask), s = LC_QBITS - L;
        const uint64_t cm = pm >> (3u * (depth - L));
        const int32_t cx = (int32_t)lc_morton_compact3(cm), cy = (int32_t)lc_morton_compact3(cm >> 1),
                      cz = (int32_t)lc_morton_compact3(cm >> 2);
        const LC_T *eb = boxes + 6 * (size_t)idx;
        lc_rec me;
        size_t r, first;

        if (p + LC_PREFETCH < end)
            __builtin_prefetch(boxes + 6 * (size_t)(entries[p + LC_PREFETCH] & imask));
        LC_FN(make_rec_)(g, eb, idx, &me);

        while (nseg) {
            const lc_seg *sg = &segs[nseg - 1];
            if (sg->level <= L && (pm >> (3u * (depth - sg->level))) == sg->cm)
                break;
            ncand = sg->start;
            nseg--;
        }
        if (!nseg || segs[nseg - 1].level != L) {
            st = lc_open_segment(g, o, &cand, segs, &nseg, &ncand, pm, L, 1);
            if (st)
                return st;
        } else if (ncand + 1 > o->cand.cap) {
            st = lc_buf_reserve(o->alloc, &o->cand, sizeof(lc_rec), ncand + 1);
            if (st)
                return st;
            cand = (lc_rec *)o->cand.data;
        }
        first = segs[nseg - 1].start;
        if (npairs + (ncand - first) > o->pairs.cap / 2) {
            st = lc_buf_reserve(o->alloc, &o->pairs, sizeof(uint32_t), 2 * (npairs + (ncand - first)));
            if (st)
                return st;
            pairs = (uint32_t *)o->pairs.data;
        }
        candidates += ncand - first;
        for (r = first; r < ncand; r++) {
            const lc_rec *c = &cand[r];
            int32_t mx, my, mz;
            if ((c->hi[0] < me.lo[0]) | (me.hi[0] < c->lo[0]) | (c->hi[1] < me.lo[1]) | (me.hi[1] < c->lo[1]) |
                (c->hi[2] < me.lo[2]) | (me.hi[2] < c->lo[2]))
                continue;
            mx = c->lo[0] > me.lo[0] ? c->lo[0] : me.lo[0];
            my = c->lo[1] > me.lo[1] ? c->lo[1] : me.lo[1];
            mz = c->lo[2] > me.lo[2] ? c->lo[2] : me.lo[2];
            if (((mx >> s) != cx) | ((my >> s) != cy) | ((mz >> s) != cz))
                continue; /* reported in another cell */
            if (!((c->hi[0] > me.lo[0]) & (me.hi[0] > c->lo[0]) & (c->hi[1] > me.lo[1]) & (me.hi[1] > c->lo[1]) &
                  (c->hi[2] > me.lo[2]) & (me.hi[2] > c->lo[2]))) {
                exact++;
                if (!LC_FN(exact_overlap_)(eb, boxes + 6 * (size_t)c->idx))
                    continue;
            }
            if (c->idx < idx) {
                pairs[2 * npairs] = c->idx;
                pairs[2 * npairs + 1] = idx;
            } else {
                pairs[2 * npairs] = idx;
                pairs[2 * npairs + 1] = c->idx;
            }
            npairs++;
        }
        cand[ncand++] = me;
    }
    o->count = npairs;
    o->candidates += candidates;
    o->exact_tests += exact;
    return LOCD_OK;
}

#undef LC_FN
#undef LC_CAT
#undef LC_CAT2
