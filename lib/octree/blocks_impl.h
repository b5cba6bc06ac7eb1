/* The building blocks' bodies for one precision, with the kernel as an
 * argument. Included by blocks.c once per precision with LC_T and LC_SUFFIX
 * defined (the include-template of octree.h). */

locd_status LC_FN(lc_block_grid_fit_)(const LC_T *boxes, size_t n, uint32_t max_depth, int32_t cell_bias,
                                      uint32_t flags, locd_grid *grid, int kernel)
{
    lc_bounds b;
    locd_grid g;
    locd_status st;
    if (!grid || (!boxes && n))
        return lc_error(LOCD_ERR_NULL_POINTER, "%s is NULL", grid ? "boxes" : "grid");
    if ((uint64_t)n > (uint64_t)UINT32_MAX + 1u)
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "%zu objects do not fit a 32-bit index", n);
    lc_bounds_init(&b);
    LC_FN(lc_bounds_)(boxes, 0, n, &b, kernel);
    if (b.bad >= 0)
        return lc_error_box(b.bad_status, b.bad, "box %lld", (long long)b.bad);
    st = lc_grid_from_bounds(&b, n, max_depth, cell_bias, flags, &g);
    if (!st && !max_depth)
        LC_FN(lc_grid_tune_depth_)(&g, boxes, n);
    if (!st) {
        grid_out(grid, &g);
        lc_clear_error();
    }
    return st;
}

locd_status LC_FN(lc_block_encode_)(const locd_grid *grid, const LC_T *boxes, size_t first, size_t count,
                                    uint64_t *entries, size_t capacity, size_t *written, int kernel)
{
    size_t need = 0, w;
    locd_status st = lc_grid_check(grid);
    if (st)
        return st;
    if (!written || (count && (!boxes || !entries)))
        return lc_error(LOCD_ERR_NULL_POINTER, "boxes, entries and written must not be NULL");
    *written = 0;
    if (count && (first + count < first || (uint64_t)(first + count - 1) >> grid->index_bits))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "object indices exceed the grid's %u index bits",
                        grid->index_bits);
    w = LC_FN(lc_encode_)(grid, boxes, first, count, entries, capacity, &need, NULL, kernel);
    if (w == (size_t)-1) {
        *written = need;
        return lc_error(LOCD_ERR_BUFFER_TOO_SMALL, "entries need up to %zu slots, capacity %zu", need,
                        capacity);
    }
    *written = w;
    lc_clear_error();
    return LOCD_OK;
}

locd_status LC_FN(lc_block_sweep_)(const locd_grid *grid, const LC_T *boxes, size_t n, const uint64_t *entries,
                                   size_t count, size_t split, locd_pairs *out, locd_stats *stats, int kernel)
{
    return LC_FN(lc_block_sweep_range_)(grid, boxes, n, entries, count, 0, count, split, out, stats, kernel);
}

locd_status LC_FN(lc_block_sweep_range_)(const locd_grid *grid, const LC_T *boxes, size_t n, const uint64_t *entries,
                                         size_t count, size_t begin, size_t end, size_t split, locd_pairs *out,
                                         locd_stats *stats, int kernel)
{
    lc_sweep_out o;
    locd_status st = lc_grid_check(grid);
    size_t i;
    if (st)
        return st;
    if ((st = lc_pairs_check(out)) != LOCD_OK)
        return st;
    if (count && (!entries || !boxes))
        return lc_error(LOCD_ERR_NULL_POINTER, "entries and boxes must not be NULL");
    if (stats && (st = lc_struct_check(stats, sizeof *stats, LOCD_STATS_MIN_SIZE, "stats")) != LOCD_OK)
        return st;
    if (begin > end || end > count)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "range [%zu, %zu) outside the %zu entries", begin, end, count);
    if (!entries_sorted(entries, count))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "entries are not strictly ascending");
    for (i = 0; i < count; i++)
        if ((entries[i] & ((1ull << grid->index_bits) - 1)) >= n)
            return lc_error(LOCD_ERR_INVALID_ARGUMENT, "entry %zu names object >= n", i);
    lc_sweep_out_init(&o, &out->alloc, kernel);
    o.split = (uint32_t)split;
    /* An empty out's buffer has nothing to keep: the sweep writes into it
       directly (one copy of the pairs fewer) while it has room. */
    if (out->count == 0 && out->cap)
        lc_sweep_out_lend(&o, out->data, 2 * out->cap);
    st = LC_FN(lc_sweep_range_)(grid, boxes, NULL, entries, count, begin, end, &o);
    if (!st && !(o.pairs_lent && o.pairs.data == (void *)out->data))
        st = lc_pairs_reserve(out, o.count);
    if (!st) {
        if (o.count && o.pairs.data != (void *)out->data)
            memcpy(out->data, o.pairs.data, o.count * 2 * sizeof(uint32_t));
        if (split) /* two sets: the sweep wrote (i, split + j) */
            for (i = 0; i < o.count; i++)
                out->data[2 * i + 1] -= (uint32_t)split;
        out->count = o.count;
        if (stats)
            sweep_stats_out(stats, n, count, &o);
        lc_clear_error();
    }
    lc_sweep_out_fini(&o);
    return st;
}

#undef LC_T
#undef LC_SUFFIX
