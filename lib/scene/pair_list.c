/* Sorted pair lists. A row is two ids (first < second); rows sort by
 * (first, second), which is the order of the key serial_a << 32 | serial_b
 * (ids sort by serial, scene.h). The sort is an LSD radix sort of the rows
 * themselves on 11-bit digits of the serials, second then first, over the
 * bits the serials use: four passes at up to 2^22 serials. (It sorted
 * keys and positions on bytes, six passes and a gather of the rows after:
 * about 0.3 ms of a 1%-moved frame's 2x10^4 new rows at 10^6 cubes.) */
#include "scene/scene.h"

locd_status lc_pair_list_reserve(const locd_allocator *a, lc_pair_list *p, size_t rows)
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

void lc_pair_list_fini(const locd_allocator *a, lc_pair_list *p)
{
    lc_buf_release(a, &p->rows, 2 * sizeof(locd_id));
    p->count = 0;
    p->first = 0;
}

#define LC_ROW_DIGIT 11
/* Up to this many rows an insertion sort beats the passes, whose counts
 * (2^11 each) cost the same for 2 rows as for 2,000. */
#define LC_ROW_SORT_SHORT 64

/* A row's place in the order: the first id's serial, then the second's. */
LC_INLINE uint64_t row_key(const locd_id *r)
{
    return (uint64_t)LC_ID_SERIAL(r[0]) << 32 | LC_ID_SERIAL(r[1]);
}

/* Stable, as the passes are: rows of one key keep their order. */
static void rows_insertion_sort(locd_id *rows, size_t n)
{
    size_t i, j;
    for (i = 1; i < n; i++) {
        const locd_id r0 = rows[2 * i], r1 = rows[2 * i + 1];
        const uint64_t k = row_key(&rows[2 * i]);
        for (j = i; j > 0 && row_key(&rows[2 * (j - 1)]) > k; j--)
            rows[2 * j] = rows[2 * (j - 1)], rows[2 * j + 1] = rows[2 * (j - 1) + 1];
        rows[2 * j] = r0, rows[2 * j + 1] = r1;
    }
}

locd_status lc_pair_rows_sort(const locd_allocator *a, locd_id *rows, size_t n)
{
    const uint32_t nb = 1u << LC_ROW_DIGIT;
    size_t *count, i;
    locd_id *tmp, *src = rows, *dst;
    uint32_t used[2] = {0, 0}, f;
    if (n <= LC_ROW_SORT_SHORT) {
        rows_insertion_sort(rows, n);
        return LOCD_OK;
    }
    tmp = lc_alloc(a, 2 * n * sizeof *tmp + nb * sizeof *count);
    if (!tmp)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the pair sort's scratch");
    count = (size_t *)(tmp + 2 * n);
    dst = tmp;
    for (i = 0; i < n; i++)
        used[0] |= LC_ID_SERIAL(rows[2 * i]), used[1] |= LC_ID_SERIAL(rows[2 * i + 1]);
    for (f = 2; f-- > 0;) { /* the second serial, then the first */
        uint32_t sh;
        for (sh = 0; sh < 32 && (used[f] >> sh); sh += LC_ROW_DIGIT) {
            size_t sum = 0;
            uint32_t b, d0 = (LC_ID_SERIAL(src[f]) >> sh) & (nb - 1);
            locd_id *t;
            memset(count, 0, nb * sizeof *count);
            for (i = 0; i < n; i++)
                count[(LC_ID_SERIAL(src[2 * i + f]) >> sh) & (nb - 1)]++;
            if (count[d0] == n) /* one digit: the pass would change nothing */
                continue;
            for (b = 0; b < nb; b++) {
                size_t c = count[b];
                count[b] = sum;
                sum += c;
            }
            for (i = 0; i < n; i++) {
                size_t d = count[(LC_ID_SERIAL(src[2 * i + f]) >> sh) & (nb - 1)]++;
                dst[2 * d] = src[2 * i], dst[2 * d + 1] = src[2 * i + 1];
            }
            t = src, src = dst, dst = t;
        }
    }
    if (src != rows)
        memcpy(rows, src, 2 * n * sizeof *rows);
    lc_free(a, tmp, 2 * n * sizeof *tmp + nb * sizeof *count);
    return LOCD_OK;
}

void lc_pair_rows_diff(const locd_id *a, size_t na, const locd_id *b, size_t nb, locd_id *amb, size_t *namb, locd_id *bma,
                   size_t *nbma)
{
    size_t i = 0, j = 0, wa = 0, wb = 0;
    while (i < na && j < nb) {
        uint64_t ka, kb;
        /* Most rows are in both (a frame's set against the last one's):
           skip equal rows four at a time, one branch per four, where the
           three-way test below took a hard-to-predict branch a row. Equal
           ids are equal rows (a serial is one object's). */
        while (i + 4 <= na && j + 4 <= nb) {
            uint64_t x = 0;
            int q;
            for (q = 0; q < 8; q++)
                x |= a[2 * i + q] ^ b[2 * j + q];
            if (x)
                break;
            i += 4, j += 4;
        }
        if (i == na || j == nb)
            break;
        ka = lc_pair_key(a + 2 * i), kb = lc_pair_key(b + 2 * j);
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

typedef struct rows_at {
    const locd_id *rows;
    uint64_t key;
} rows_at;

static int row_at_or_above(const void *ctx, uint64_t i)
{
    const rows_at *c = ctx;
    return lc_pair_key(c->rows + 2 * i) >= c->key;
}

size_t lc_pair_rows_lower_bound(const locd_id *rows, size_t n, uint64_t key)
{
    rows_at c;
    c.rows = rows, c.key = key;
    return (size_t)lc_search_first(0, n, row_at_or_above, &c);
}
