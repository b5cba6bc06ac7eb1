/* lib/core: what every folder above uses (errors, memory, pairs, the
 * thread pool, the CPU kernel choice, time). Private; not installed. */
#ifndef LOCD_CORE_H
#define LOCD_CORE_H

#include "locd/locd.h"

#include <stdarg.h>
#include <string.h>

/* C++ sees this header through narrow/narrow.h (narrow/fcl_glue.cpp). */
#ifdef __cplusplus
extern "C" {
#endif

#if defined(__GNUC__)
#define LC_LIKELY(x) __builtin_expect(!!(x), 1)
#define LC_UNLIKELY(x) __builtin_expect(!!(x), 0)
#define LC_INLINE static __inline__ __attribute__((always_inline))
#define LC_TLS __thread
#if defined(__MINGW32__)
/* mingw-w64, built with __USE_MINGW_ANSI_STDIO=1 (meson.build): C99 formats (%zu). */
#define LC_PRINTF(a, b) __attribute__((format(gnu_printf, a, b)))
#else
#define LC_PRINTF(a, b) __attribute__((format(printf, a, b)))
#endif
#else
#define LC_LIKELY(x) (x)
#define LC_UNLIKELY(x) (x)
#define LC_INLINE static
#define LC_TLS
#define LC_PRINTF(a, b)
#endif

/* The few helpers liblocd_narrow (lib/narrow/, a library of its own) calls
 * in liblocd: marked LC_SHARED, exported only in the private version node
 * LOCD_PRIVATE_<version> of lib/locd.map.in, declared in no public header,
 * no part of the ABI (docs/abi.md, "Two libraries"). The error helpers must
 * be liblocd's own: the last error is liblocd's thread-local state. */
#if defined(_WIN32) && defined(LOCD_SHARED_BUILD) && !defined(LOCD_NARROW_BUILD)
#define LC_SHARED __declspec(dllexport)
#elif defined(_WIN32)
#define LC_SHARED
#elif defined(__GNUC__)
#define LC_SHARED __attribute__((visibility("default")))
#else
#define LC_SHARED
#endif

/* Handle kinds: the first field of every handle, checked on entry (and of
 * level 2's shared control block). One list, so that no two kinds share a
 * value and a handle of one kind passed as another is refused. "LOC" and a
 * letter: C99 wants enumerators that fit an int. */
enum lc_magic {
    LC_MAGIC_ENGINE = 0x4c4f4345,   /* "LOCE" */
    LC_MAGIC_PAIRS = 0x4c4f4350,    /* "LOCP" */
    LC_MAGIC_JOB = 0x4c4f434a,      /* "LOCJ" */
    LC_MAGIC_SERVICE = 0x4c4f4356,  /* "LOCV" service/server.c */
    LC_MAGIC_SHAPE = 0x4c4f4353,    /* "LOCS" narrow/ */
    LC_MAGIC_WORLD = 0x4c4f4357,    /* "LOCW" narrow/ */
    LC_MAGIC_CONTACTS = 0x4c4f434e, /* "LOCN" narrow/ */
    LC_MAGIC_SHM = 0x4c4f434d,      /* "LOCM" levels/levels.h: the shm control block */
    LC_MAGIC_SCENE = 0x4c4f4343,    /* "LOCC" scene/ */
    LC_MAGIC_HITS = 0x4c4f4348,     /* "LOCH" scene/query_batch.c */
    LC_MAGIC_DEAD = 0x4c4f4358      /* "LOCX" a destroyed handle */
};

/* The most threads (level 1), worker processes (level 2) or sorted runs one
 * merge takes: per-thread state lives in fixed arrays of this size. */
#define LC_MAX_THREADS 64

/* Conventions of the internal functions:
 *   - a function that can fail returns a locd_status: LOCD_OK, or the
 *     LOCD_ERR_* it raised with lc_error (the caller only passes it on);
 *   - a predicate, or a check that does not raise, returns int 1 (true/ok)
 *     or 0;
 *   - a test whose answer is yes/no and that can also fail returns int 1 or
 *     0, or a negative locd_status it raised (the narrow phase's pair tests);
 *   - a function that can fail and reports its reason in a `why` buffer
 *     instead of raising (the service's connection threads, whose reasons go
 *     to a log line or a job) returns int 1 on success, 0 on failure;
 *   - a function that cannot fail returns void or its result.
 * Every public function clears the last error (lc_clear_error) on each path
 * that returns a status >= 0. */

/* ---- errors (error.c) ---- */
LC_SHARED locd_status lc_error(locd_status status, const char *fmt, ...) LC_PRINTF(2, 3);
LC_SHARED locd_status lc_error_box(locd_status status, int64_t index, const char *fmt, ...) LC_PRINTF(3, 4);
LC_SHARED void lc_clear_error(void);
/* The detail of the calling thread's last error without the status text
 * that locd_last_error() puts in front ("" when none): what is passed on
 * when an error is raised again elsewhere (a job, the service's reply). */
LC_SHARED const char *lc_last_error_detail(void);
/* Formats a message and hands it to a user log hook (nothing when log is NULL). */
void lc_log_emit(locd_log_fn log, void *user, int32_t severity, const char *fmt, va_list ap);

/* ---- memory (alloc.c) ---- */
LC_SHARED void lc_allocator_resolve(locd_allocator *dst, const locd_allocator *src);
LC_SHARED void *lc_alloc(const locd_allocator *a, size_t size);
LC_SHARED void lc_free(const locd_allocator *a, void *ptr, size_t size);
/* size * count with overflow check; returns 0 on overflow. */
LC_SHARED int lc_mul_size(size_t a, size_t b, size_t *out);
/* A growable array of `elem` sized items owned through an allocator. */
typedef struct lc_buf {
    void *data;
    size_t cap; /* in elements */
} lc_buf;
/* The capacity a growing buffer of `cap` moves to when it needs `need`:
 * half as much again (amortized O(1) appends), or `need` if more. */
LC_SHARED size_t lc_grow_cap(size_t cap, size_t need);
LC_SHARED locd_status lc_buf_reserve(const locd_allocator *a, lc_buf *b, size_t elem, size_t count);
LC_SHARED void lc_buf_release(const locd_allocator *a, lc_buf *b, size_t elem);

/* ---- the lower-bound search (the library's one) ----
 * The first x in [lo, hi) at which at(ctx, x) is true, given that it is
 * false then true along [lo, hi) (hi when it never is true): a sorted
 * array's first element >= v (lc_lower_bound), a sorted list of pair rows,
 * the smallest depth or value a monotone estimate allows. Inline, with a
 * constant `at` the compiler inlines, it is the plain loop. */
LC_INLINE uint64_t lc_search_first(uint64_t lo, uint64_t hi, int (*at)(const void *ctx, uint64_t x), const void *ctx)
{
    while (lo < hi) {
        const uint64_t mid = lo + (hi - lo) / 2;
        if (at(ctx, mid))
            hi = mid;
        else
            lo = mid + 1;
    }
    return lo;
}

/* The first position of sorted a[0, n) whose value is >= v (n if none).
 * lc_lower_bound (search.c) is the copy liblocd calls; lib/mpi, which
 * cannot call liblocd's own functions, uses lc_lower_bound_inline. */
typedef struct lc_sorted_key {
    const uint64_t *a;
    uint64_t v;
} lc_sorted_key;

LC_INLINE int lc_at_or_above(const void *ctx, uint64_t i)
{
    const lc_sorted_key *k = (const lc_sorted_key *)ctx;
    return k->a[i] >= k->v;
}

LC_INLINE size_t lc_lower_bound_inline(const uint64_t *a, size_t n, uint64_t v)
{
    lc_sorted_key k;
    k.a = a, k.v = v;
    return (size_t)lc_search_first(0, n, lc_at_or_above, &k);
}

size_t lc_lower_bound(const uint64_t *a, size_t n, uint64_t v);
size_t lc_lower_bound_u32(const uint32_t *a, size_t n, uint32_t v);

/* ---- versioned structs (versioned.c; docs/abi.md, "the size rules") ---- */
/* Input: src (a public struct that leads with uint32_t size) must have
 * min_size <= size <= full_size; its first `size` bytes after `size` are
 * copied over dst, which holds the defaults (full_size bytes); dst->size is
 * kept. NULL src, or a size out of range, raise (what names the argument). */
LC_SHARED locd_status lc_struct_in(void *dst, size_t full_size, const void *src, size_t min_size, const char *what);
/* A caller's struct (in or out) is not NULL and has min_size <= size <= full_size. */
LC_SHARED locd_status lc_struct_check(const void *dst, size_t full_size, size_t min_size, const char *what);
/* Copies the library's full struct src into the caller's dst (checked by
 * lc_struct_check) no further than dst->size, and keeps dst->size. */
LC_SHARED void lc_struct_out(void *dst, const void *src);

/* ---- SIMD kernels (kernel.c) ---- */
/* AVX2 and AVX-512 on x86-64, NEON on aarch64: a machine has scalar and
 * one family, so only the x86 values are ordered (AVX-512 > AVX2). */
enum { LC_KERNEL_SCALAR, LC_KERNEL_AVX2, LC_KERNEL_AVX512, LC_KERNEL_NEON };
/* The best kernel family this CPU has, capped by LOCD_KERNEL / LOCD_SCALAR.
 * It reads the environment and the CPU, so it is called once where a choice
 * can live: when an engine's level state is created; the stages take the
 * choice as an argument. The public building blocks have no engine and
 * choose per call. */
LC_SHARED int lc_kernel_choose(void);
#if defined(__GNUC__) && defined(__x86_64__) && (__GNUC__ >= 8 || defined(__clang__))
#define LC_HAVE_AVX512_KERNEL 1
#define LC_AVX512 __attribute__((target("avx512f,avx512vl,avx512bw,avx512dq,avx512cd,popcnt,bmi,bmi2")))
#endif

/* ---- time ---- */
LC_SHARED double lc_now_ms(void);

/* ---- shared-memory segment names (shm.c) ---- */
#define LC_SHM_PREFIX "/locd-"
/* Writes a fresh segment name, LC_SHM_PREFIX tag pid-counter-clock, to out. */
void lc_shm_unique_name(char *out, size_t len, const char *tag);

/* ---- pairs (pairs.c) ---- */
struct locd_pairs {
    uint32_t magic;
    locd_allocator alloc;
    uint32_t *data; /* 2 * cap values */
    size_t count;
    size_t cap; /* pairs */
};
locd_status lc_pairs_check(const locd_pairs *p);
LC_SHARED locd_status lc_pairs_reserve(locd_pairs *p, size_t pairs);
/* Sorts 2*count interleaved uint32 pairs by (i, j); scratch of count uint64. */
void lc_sort_pair_array(uint32_t *pairs, size_t count, uint64_t *scratch);
locd_status lc_pairs_init_embedded(locd_pairs *p, const locd_allocator *a);
void lc_pairs_fini_embedded(locd_pairs *p);
/* Hands the finished pairs of *from over to *out, replacing out's: a swap of
 * buffers when both use the same allocator (from keeps out's old buffer,
 * emptied), else a copy. On failure *out is unchanged. */
locd_status lc_pairs_give(locd_pairs *from, locd_pairs *out);

/* ---- radix sort (radix_sort.c) ---- */
/* Sorts 64-bit keys whose low `index_bits` bits are already ascending
 * within equal high bits (stable LSD passes over the bits that vary);
 * returns the buffer holding the result (entries or scratch). */
LC_SHARED uint64_t *lc_radix_sort(uint64_t *entries, uint64_t *scratch, size_t count, uint32_t index_bits);
/* Sorts v[0, n) ascending: a shell sort below LC_RADIX_SORT_MIN values,
 * qsort from there (lc_sort_u64), or the radix sort (lc_sort_u64_radix,
 * its scratch allocated). */
void lc_sort_u64(uint64_t *v, size_t n);
locd_status lc_sort_u64_radix(const locd_allocator *a, uint64_t *v, size_t n);

/* ---- thread pool (pool.c) ---- */
typedef struct lc_pool lc_pool;
typedef void (*lc_task_fn)(void *ctx, uint32_t tid, uint32_t nthreads);
locd_status lc_pool_create(const locd_allocator *a, uint32_t threads, lc_pool **out);
void lc_pool_destroy(lc_pool *p);
/* Runs fn(ctx, t, k) once for each part t = 0..k-1 (k <= pool size) and
 * returns when all are done. A part runs on the caller or on a worker,
 * whichever claims it first, so one thread may run several parts one
 * after another: a part must never wait for another. */
void lc_pool_run(lc_pool *p, uint32_t k, lc_task_fn fn, void *ctx);
uint32_t lc_cpu_count(void);

#ifdef __cplusplus
}
#endif

#endif
