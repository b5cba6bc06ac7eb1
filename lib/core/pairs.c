/* locd_pairs: the growable result buffer. */
#include "core/core.h"

locd_status lc_pairs_check(const locd_pairs *p)
{
    if (!p)
        return lc_error(LOCD_ERR_NULL_POINTER, "pairs buffer is NULL");
    if (p->magic != LC_MAGIC_PAIRS)
        return lc_error(LOCD_ERR_INVALID_HANDLE, "not a locd_pairs handle (destroyed?)");
    return LOCD_OK;
}

locd_status lc_pairs_init_embedded(locd_pairs *p, const locd_allocator *a)
{
    memset(p, 0, sizeof *p);
    p->magic = LC_MAGIC_PAIRS;
    lc_allocator_resolve(&p->alloc, a);
    return LOCD_OK;
}

void lc_pairs_fini_embedded(locd_pairs *p)
{
    lc_free(&p->alloc, p->data, p->cap * 2 * sizeof(uint32_t));
    p->data = NULL;
    p->cap = p->count = 0;
    p->magic = LC_MAGIC_DEAD;
}

locd_status locd_pairs_create(const locd_allocator *allocator, locd_pairs **out)
{
    locd_allocator a;
    locd_pairs *p;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    *out = NULL;
    lc_allocator_resolve(&a, allocator);
    p = lc_alloc(&a, sizeof *p);
    if (!p)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate a pairs buffer");
    lc_pairs_init_embedded(p, &a);
    *out = p;
    lc_clear_error();
    return LOCD_OK;
}

void locd_pairs_destroy(locd_pairs *pairs)
{
    locd_allocator a;
    if (!pairs || pairs->magic != LC_MAGIC_PAIRS)
        return;
    a = pairs->alloc;
    lc_pairs_fini_embedded(pairs);
    lc_free(&a, pairs, sizeof *pairs);
}

size_t locd_pairs_count(const locd_pairs *pairs)
{
    return (pairs && pairs->magic == LC_MAGIC_PAIRS) ? pairs->count : 0;
}

const uint32_t *locd_pairs_data(const locd_pairs *pairs)
{
    return (pairs && pairs->magic == LC_MAGIC_PAIRS) ? pairs->data : NULL;
}

void locd_pairs_clear(locd_pairs *pairs)
{
    if (pairs && pairs->magic == LC_MAGIC_PAIRS)
        pairs->count = 0;
}

locd_status lc_pairs_reserve(locd_pairs *p, size_t pairs)
{
    size_t bytes, cap;
    uint32_t *d;
    if (pairs <= p->cap)
        return LOCD_OK;
    cap = lc_grow_cap(p->cap, pairs);
    if (!lc_mul_size(cap, 2 * sizeof(uint32_t), &bytes))
        return lc_error(LOCD_ERR_NO_MEMORY, "%zu pairs overflow size_t", cap);
    d = lc_alloc(&p->alloc, bytes);
    if (!d)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate %zu pairs", cap);
    if (p->count)
        memcpy(d, p->data, p->count * 2 * sizeof(uint32_t));
    lc_free(&p->alloc, p->data, p->cap * 2 * sizeof(uint32_t));
    p->data = d;
    p->cap = cap;
    return LOCD_OK;
}

static int same_allocator(const locd_allocator *a, const locd_allocator *b)
{
    return a->alloc == b->alloc && a->free == b->free && a->user == b->user;
}

locd_status lc_pairs_give(locd_pairs *from, locd_pairs *out)
{
    locd_status st;
    if (same_allocator(&from->alloc, &out->alloc)) {
        locd_pairs t = *out;
        out->data = from->data;
        out->cap = from->cap;
        out->count = from->count;
        from->data = t.data;
        from->cap = t.cap;
        from->count = 0;
        return LOCD_OK;
    }
    if ((st = lc_pairs_reserve(out, from->count)) != LOCD_OK)
        return st;
    if (from->count)
        memcpy(out->data, from->data, from->count * 2 * sizeof(uint32_t));
    out->count = from->count;
    return LOCD_OK;
}

void lc_sort_pair_array(uint32_t *pairs, size_t count, uint64_t *scratch)
{
    /* The pairs array is the sort's first buffer: each pair (two uint32,
       8 bytes, 16-byte aligned by the allocator contract) becomes its
       (i << 32 | j) key in place, so sorting costs 8 bytes a pair, not 16. */
    uint64_t *keys = (uint64_t *)(void *)pairs, *sorted;
    size_t k;
    for (k = 0; k < count; k++) {
        const uint32_t i = pairs[2 * k], j = pairs[2 * k + 1];
        keys[k] = ((uint64_t)i << 32) | j;
    }
    sorted = lc_radix_sort(keys, scratch, count, 0);
    for (k = 0; k < count; k++) {
        const uint64_t v = sorted[k];
        pairs[2 * k] = (uint32_t)(v >> 32);
        pairs[2 * k + 1] = (uint32_t)v;
    }
}

locd_status locd_pairs_sort(locd_pairs *pairs)
{
    locd_status st = lc_pairs_check(pairs);
    size_t bytes;
    uint64_t *tmp;
    if (st)
        return st;
    if (pairs->count < 2) {
        lc_clear_error();
        return LOCD_OK;
    }
    if (!lc_mul_size(pairs->count, sizeof(uint64_t), &bytes))
        return lc_error(LOCD_ERR_NO_MEMORY, "too many pairs to sort");
    tmp = lc_alloc(&pairs->alloc, bytes);
    if (!tmp)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate %zu bytes to sort pairs", bytes);
    lc_sort_pair_array(pairs->data, pairs->count, tmp);
    lc_free(&pairs->alloc, tmp, bytes);
    lc_clear_error();
    return LOCD_OK;
}
