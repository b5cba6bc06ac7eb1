/* Sorted pair lists. A row is two ids (first < second); rows sort by
 * (first, second), which is the order of the key serial_a << 32 | serial_b
 * (ids sort by serial, scene.h). The sort is an LSD radix sort of the keys
 * carrying each row's position, over the bytes that vary only. */
#include "scene/scene.h"

locd_status lc_plist_reserve(const locd_allocator *a, lc_plist *p, size_t rows)
{
    /* A list that must grow gets an eighth more than asked for: a set
       grows a little from frame to frame, and the scene keeps its lists
       (the spares), so the next frames then fit. Asked for exactly, a
       million-pair list was made new (16 MB, copied and faulted in) in each
       of the first incremental frames. */
    if (rows <= p->rows.cap)
        return LOCD_OK;
    return lc_buf_reserve(a, &p->rows, 2 * sizeof(locd_id), rows + rows / 8);
}

void lc_plist_fini(const locd_allocator *a, lc_plist *p)
{
    lc_buf_release(a, &p->rows, 2 * sizeof(locd_id));
    p->count = 0;
    p->first = 0;
}

locd_status lc_pairs_sort_rows(const locd_allocator *a, locd_id *rows, size_t n)
{
    uint64_t *key, *key2, diff = 0;
    uint32_t *pos, *pos2;
    locd_id *tmp;
    size_t i, bytes;
    uint32_t b;
    if (n < 2)
        return LOCD_OK;
    bytes = n * (2 * sizeof(uint64_t) + 2 * sizeof(uint32_t) + 2 * sizeof(locd_id));
    key = lc_alloc(a, bytes);
    if (!key)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the pair sort's scratch");
    key2 = key + n;
    tmp = (locd_id *)(key2 + n);
    pos = (uint32_t *)(tmp + 2 * n);
    pos2 = pos + n;
    for (i = 0; i < n; i++) {
        key[i] = lc_pair_key(rows + 2 * i);
        pos[i] = (uint32_t)i;
        diff |= key[i] ^ key[0];
    }
    for (b = 0; b < 8; b++) {
        size_t count[256] = {0}, sum = 0;
        uint32_t sh = 8 * b;
        uint64_t *tk;
        uint32_t *tp;
        if (!((diff >> sh) & 0xff))
            continue;
        for (i = 0; i < n; i++)
            count[(key[i] >> sh) & 0xff]++;
        for (i = 0; i < 256; i++) {
            size_t c = count[i];
            count[i] = sum;
            sum += c;
        }
        for (i = 0; i < n; i++) {
            size_t d = count[(key[i] >> sh) & 0xff]++;
            key2[d] = key[i];
            pos2[d] = pos[i];
        }
        tk = key, key = key2, key2 = tk;
        tp = pos, pos = pos2, pos2 = tp;
    }
    for (i = 0; i < n; i++) {
        tmp[2 * i] = rows[2 * (size_t)pos[i]];
        tmp[2 * i + 1] = rows[2 * (size_t)pos[i] + 1];
    }
    memcpy(rows, tmp, 2 * n * sizeof(locd_id));
    /* key may have been swapped with key2: free the block by its start. */
    lc_free(a, key < key2 ? key : key2, bytes);
    return LOCD_OK;
}

void lc_plist_diff(const locd_id *a, size_t na, const locd_id *b, size_t nb, locd_id *amb, size_t *namb, locd_id *bma,
                   size_t *nbma)
{
    size_t i = 0, j = 0, wa = 0, wb = 0;
    while (i < na && j < nb) {
        uint64_t ka = lc_pair_key(a + 2 * i), kb = lc_pair_key(b + 2 * j);
        if (ka < kb) {
            amb[2 * wa] = a[2 * i], amb[2 * wa + 1] = a[2 * i + 1], wa++, i++;
        } else if (kb < ka) {
            bma[2 * wb] = b[2 * j], bma[2 * wb + 1] = b[2 * j + 1], wb++, j++;
        } else {
            i++, j++;
        }
    }
    for (; i < na; i++)
        amb[2 * wa] = a[2 * i], amb[2 * wa + 1] = a[2 * i + 1], wa++;
    for (; j < nb; j++)
        bma[2 * wb] = b[2 * j], bma[2 * wb + 1] = b[2 * j + 1], wb++;
    *namb = wa, *nbma = wb;
}

/* The first row of sorted rows[0, n) whose key is >= key. */
size_t lc_rows_lower_bound(const locd_id *rows, size_t n, uint64_t key)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (lc_pair_key(rows + 2 * mid) < key)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}
