#include "fail_alloc.h"

#include <pthread.h>
#include <stdlib.h>
#ifdef _WIN32
#include <malloc.h>
#endif
#include <string.h>

/* Each block carries a header with its size and a tag, so a free() with the
 * wrong size or of a foreign pointer is counted instead of crashing. 16 bytes
 * keep the user pointer 16-aligned as the hook's contract asks. */
#define FA_TAG 0x6c6f6364u
typedef struct fa_header {
    uint64_t size;
    uint32_t tag;
    uint32_t pad;
} fa_header;

static pthread_mutex_t fa_mu = PTHREAD_MUTEX_INITIALIZER;
static fa_counts fa_c;
static uint64_t fa_k;
static int fa_sticky;

static void *fa_alloc(size_t size, void *user)
{
    fa_header *h;
    void *mem;
    int fail;
    (void)user;
    pthread_mutex_lock(&fa_mu);
    fa_c.calls++;
    fail = fa_k && (fa_c.calls == fa_k || (fa_sticky && fa_c.calls > fa_k));
    if (fail)
        fa_c.failures++;
    pthread_mutex_unlock(&fa_mu);
    if (fail || size > (size_t)-1 - sizeof *h)
        return NULL;
#ifdef _WIN32 /* (mingw has no posix_memalign) */
    if (!(mem = _aligned_malloc(sizeof *h + size, 16)))
        return NULL;
#else
    if (posix_memalign(&mem, 16, sizeof *h + size) != 0)
        return NULL;
#endif
    h = mem;
    h->size = size;
    h->tag = FA_TAG;
    h->pad = 0;
    pthread_mutex_lock(&fa_mu);
    fa_c.live_blocks++;
    fa_c.live_bytes += size;
    pthread_mutex_unlock(&fa_mu);
    return h + 1;
}

static void fa_free(void *ptr, size_t size, void *user)
{
    fa_header *h;
    (void)user;
    if (!ptr)
        return;
    h = (fa_header *)ptr - 1;
    pthread_mutex_lock(&fa_mu);
    if (h->tag != FA_TAG || h->size != size) {
        fa_c.bad_frees++;
        pthread_mutex_unlock(&fa_mu);
        return; /* leak it rather than corrupt the heap */
    }
    fa_c.live_blocks--;
    fa_c.live_bytes -= size;
    pthread_mutex_unlock(&fa_mu);
    h->tag = 0;
#ifdef _WIN32
    _aligned_free(h);
#else
    free(h);
#endif
}

static const locd_allocator fa_hook = {fa_alloc, fa_free, NULL};

const locd_allocator *fa_allocator(void)
{
    return &fa_hook;
}

void fa_arm(uint64_t k, int sticky)
{
    pthread_mutex_lock(&fa_mu);
    fa_k = k;
    fa_sticky = sticky;
    fa_c.calls = 0;
    fa_c.failures = 0;
    pthread_mutex_unlock(&fa_mu);
}

void fa_counts_get(fa_counts *out)
{
    pthread_mutex_lock(&fa_mu);
    *out = fa_c;
    pthread_mutex_unlock(&fa_mu);
}
