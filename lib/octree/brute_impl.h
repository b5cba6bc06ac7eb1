/* The O(n^2) reference for one precision. Included by brute.c once per
 * precision with LC_T and LC_SUFFIX defined (the include-template of
 * octree.h). */

static locd_status LC_FN(brute_force_)(const LC_T *boxes, size_t n, locd_pairs *out)
{
    locd_pairs tmp;
    locd_status st;
    size_t i, j;
    if ((st = lc_pairs_check(out)) != LOCD_OK)
        return st;
    if (n && !boxes)
        return lc_error(LOCD_ERR_NULL_POINTER, "boxes is NULL");
    if ((uint64_t)n > (uint64_t)UINT32_MAX + 1u)
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "%zu objects do not fit a 32-bit index", n);
    {
        locd_grid g;
        if ((st = LC_FN(locd_grid_fit_)(boxes, n, 0, 1, 0, &g)) != LOCD_OK)
            return st;
    }
    lc_pairs_init_embedded(&tmp, &out->alloc);
    for (i = 0; i < n; i++) {
        const LC_T *a = boxes + 6 * i;
        for (j = i + 1; j < n; j++) {
            const LC_T *b = boxes + 6 * j;
            if (a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] &&
                b[2] <= a[5]) {
                if ((st = lc_pairs_reserve(&tmp, tmp.count + 1)) != LOCD_OK) {
                    lc_pairs_fini_embedded(&tmp);
                    return st;
                }
                tmp.data[2 * tmp.count] = (uint32_t)i;
                tmp.data[2 * tmp.count + 1] = (uint32_t)j;
                tmp.count++;
            }
        }
    }
    /* Swap the new contents in; the old buffer goes away. */
    {
        locd_pairs old = *out;
        out->data = tmp.data;
        out->count = tmp.count;
        out->cap = tmp.cap;
        tmp.data = old.data;
        tmp.cap = old.cap;
        lc_pairs_fini_embedded(&tmp);
    }
    lc_clear_error();
    return LOCD_OK;
}

#undef LC_T
#undef LC_SUFFIX
