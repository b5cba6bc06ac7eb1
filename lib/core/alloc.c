/* The allocator hook: every byte the library owns goes through here. */
#include "core/core.h"

#include <stdlib.h>
#include <time.h>
#if defined(__linux__)
#include <sys/mman.h>
#endif

/* Large blocks are asked for in transparent huge pages where Linux has them
 * (THP in "madvise" mode, Debian's default, gives them only to ranges that
 * ask). Each fresh 4 KB page costs a fault when it is first written, and in
 * a virtual machine that fault is dear: at 10^8 objects the first find
 * touched 7.4 GB, 1.9 million faults, and spent longer in the kernel than in
 * its own code (docs/benchmarks.md, "From 10^3 to 10^8"). A 2 MB page is one
 * fault for 512. Only the default allocator does this: a caller's hook owns
 * its memory. The block is 2 MB-aligned so that all of it can be huge. */
#define LC_HUGE_PAGE ((size_t)2 << 20)
#define LC_HUGE_MIN ((size_t)4 << 20)

static void *default_alloc(size_t size, void *user)
{
    (void)user;
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (size >= LC_HUGE_MIN) {
        void *p;
        if (posix_memalign(&p, LC_HUGE_PAGE, size) != 0)
            return NULL;
        /* Advice only: where THP is off or absent this fails and the block
         * stays in small pages, which is correct, only slower. */
        (void)madvise(p, size, MADV_HUGEPAGE);
        return p;
    }
#endif
    return malloc(size);
}

static void default_free(void *ptr, size_t size, void *user)
{
    (void)size;
    (void)user;
    free(ptr);
}

void lc_allocator_resolve(locd_allocator *dst, const locd_allocator *src)
{
    if (src && src->alloc && src->free) {
        *dst = *src;
    } else {
        dst->alloc = default_alloc;
        dst->free = default_free;
        dst->user = NULL;
    }
}

void *lc_alloc(const locd_allocator *a, size_t size)
{
    if (size == 0)
        size = 1;
    return a->alloc(size, a->user);
}

void lc_free(const locd_allocator *a, void *ptr, size_t size)
{
    if (ptr)
        a->free(ptr, size == 0 ? 1 : size, a->user);
}

int lc_mul_size(size_t a, size_t b, size_t *out)
{
    if (b != 0 && a > (size_t)-1 / b)
        return 0;
    *out = a * b;
    return 1;
}

size_t lc_grow_cap(size_t cap, size_t need)
{
    size_t grown = cap + cap / 2;
    return grown < need ? need : grown;
}

locd_status lc_buf_reserve(const locd_allocator *a, lc_buf *b, size_t elem, size_t count)
{
    size_t bytes, cap;
    void *p;
    if (count <= b->cap)
        return LOCD_OK;
    cap = lc_grow_cap(b->cap, count);
    if (cap < 16)
        cap = 16;
    if (!lc_mul_size(cap, elem, &bytes))
        return lc_error(LOCD_ERR_NO_MEMORY, "buffer of %zu elements overflows size_t", cap);
    p = lc_alloc(a, bytes);
    if (!p)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate %zu bytes", bytes);
    if (b->data && b->cap)
        memcpy(p, b->data, b->cap * elem);
    lc_free(a, b->data, b->cap * elem);
    b->data = p;
    b->cap = cap;
    return LOCD_OK;
}

void lc_buf_release(const locd_allocator *a, lc_buf *b, size_t elem)
{
    lc_free(a, b->data, b->cap * elem);
    b->data = NULL;
    b->cap = 0;
}

double lc_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}
