/* lib/core: what every folder above uses (errors, memory, pairs, the
 * thread pool, the CPU kernel choice, time). Private; not installed. */
#ifndef LOCD_CORE_H
#define LOCD_CORE_H

#include "locd/locd.h"

#include <stdarg.h>
#include <string.h>

#if defined(__GNUC__)
#define LC_LIKELY(x) __builtin_expect(!!(x), 1)
#define LC_UNLIKELY(x) __builtin_expect(!!(x), 0)
#define LC_INLINE static __inline__ __attribute__((always_inline))
#define LC_TLS __thread
#define LC_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define LC_LIKELY(x) (x)
#define LC_UNLIKELY(x) (x)
#define LC_INLINE static
#define LC_TLS
#define LC_PRINTF(a, b)
#endif

/* Handle kinds: the first field of every handle, checked on entry. */
#define LC_MAGIC_ENGINE 0x4c4f4345u /* "LOCE" */
#define LC_MAGIC_PAIRS 0x4c4f4350u  /* "LOCP" */
#define LC_MAGIC_JOB 0x4c4f434au    /* "LOCJ" */
#define LC_MAGIC_DEAD 0xdeadbeefu

/* ---- errors (error.c) ---- */
locd_status lc_error(locd_status status, const char *fmt, ...) LC_PRINTF(2, 3);
locd_status lc_error_box(locd_status status, int64_t index, const char *fmt, ...) LC_PRINTF(3, 4);
void lc_clear_error(void);
/* Formats a message and hands it to a user log hook (nothing when log is NULL). */
void lc_log_emit(locd_log_fn log, void *user, int32_t severity, const char *fmt, va_list ap);

/* ---- memory (alloc.c) ---- */
void lc_allocator_resolve(locd_allocator *dst, const locd_allocator *src);
void *lc_alloc(const locd_allocator *a, size_t size);
void lc_free(const locd_allocator *a, void *ptr, size_t size);
/* size * count with overflow check; returns 0 on overflow. */
int lc_mul_size(size_t a, size_t b, size_t *out);
/* A growable array of `elem` sized items owned through an allocator. */
typedef struct lc_buf {
    void *data;
    size_t cap; /* in elements */
} lc_buf;
locd_status lc_buf_reserve(const locd_allocator *a, lc_buf *b, size_t elem, size_t count);
void lc_buf_release(const locd_allocator *a, lc_buf *b, size_t elem);

/* ---- SIMD kernels (kernel.c) ---- */
enum { LC_KERNEL_SCALAR, LC_KERNEL_AVX2, LC_KERNEL_AVX512 };
/* The best kernel family this CPU has, capped by LOCD_KERNEL / LOCD_SCALAR.
 * It reads the environment and the CPU, so it is called once where a choice
 * can live: when an engine's level state is created; the stages take the
 * choice as an argument. The public building blocks have no engine and
 * choose per call. */
int lc_kernel_choose(void);
#if defined(__GNUC__) && defined(__x86_64__) && (__GNUC__ >= 8 || defined(__clang__))
#define LC_HAVE_AVX512_KERNEL 1
#define LC_AVX512 __attribute__((target("avx512f,avx512vl,avx512bw,avx512dq,avx512cd,popcnt,bmi,bmi2")))
#endif

/* ---- time ---- */
double lc_now_ms(void);

/* ---- pairs (pairs.c) ---- */
struct locd_pairs {
    uint32_t magic;
    locd_allocator alloc;
    uint32_t *data; /* 2 * cap values */
    size_t count;
    size_t cap; /* pairs */
};
locd_status lc_pairs_check(const locd_pairs *p);
locd_status lc_pairs_reserve(locd_pairs *p, size_t pairs);
/* Sorts 2*count interleaved uint32 pairs by (i, j); scratch of count uint64. */
void lc_sort_pair_array(uint32_t *pairs, size_t count, uint64_t *scratch, uint64_t *scratch2);
locd_status lc_pairs_init_embedded(locd_pairs *p, const locd_allocator *a);
void lc_pairs_fini_embedded(locd_pairs *p);

/* ---- radix sort (radix_sort.c) ---- */
/* Sorts 64-bit keys whose low `index_bits` bits are already ascending
 * within equal high bits (stable LSD passes over the bits that vary);
 * returns the buffer holding the result (entries or scratch). */
uint64_t *lc_radix_sort(uint64_t *entries, uint64_t *scratch, size_t count, uint32_t index_bits);

/* ---- thread pool (pool.c) ---- */
typedef struct lc_pool lc_pool;
typedef void (*lc_task_fn)(void *ctx, uint32_t tid, uint32_t nthreads);
locd_status lc_pool_create(const locd_allocator *a, uint32_t threads, lc_pool **out);
void lc_pool_destroy(lc_pool *p);
/* Runs fn(ctx, t, k) for t = 0..k-1 (k <= pool size; the caller runs t = 0)
 * and returns when all are done. */
void lc_pool_run(lc_pool *p, uint32_t k, lc_task_fn fn, void *ctx);
uint32_t lc_cpu_count(void);

#endif
