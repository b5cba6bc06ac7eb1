/* Versioned structs across the ABI (docs/abi.md, "the size rules"): every
 * public struct that leads with `uint32_t size` goes in and out through
 * these, so an older caller's shorter struct and a newer caller's longer one
 * are handled the same way everywhere. */
#include "core/core.h"

static uint32_t size_of(const void *s)
{
    uint32_t size;
    memcpy(&size, s, sizeof size);
    return size;
}

locd_status lc_struct_check(const void *dst, size_t full_size, size_t min_size, const char *what)
{
    uint32_t size;
    if (!dst)
        return lc_error(LOCD_ERR_NULL_POINTER, "%s is NULL", what);
    size = size_of(dst);
    if (size < min_size || size > full_size)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "%s->size is %u, not %zu..%zu: initialize it with its locd_*_init()",
                        what, size, min_size, full_size);
    return LOCD_OK;
}

locd_status lc_struct_in(void *dst, size_t full_size, const void *src, size_t min_size, const char *what)
{
    /* In and out, a size has the same range. */
    locd_status st = lc_struct_check(src, full_size, min_size, what);
    if (st)
        return st;
    /* dst holds the defaults: a shorter (older) struct keeps them for the
     * fields it lacks. dst->size stays the library's own. */
    memcpy((char *)dst + sizeof(uint32_t), (const char *)src + sizeof(uint32_t), size_of(src) - sizeof(uint32_t));
    return LOCD_OK;
}

void lc_struct_out(void *dst, const void *src)
{
    uint32_t size = size_of(dst);
    memcpy((char *)dst + sizeof size, (const char *)src + sizeof size, size - sizeof size);
}
