/* Step 4: one pass over the sorted entries finds every overlapping pair.
 *
 * The pass keeps a stack of segments, one per populated cell on the current
 * root-to-leaf path. A cell's segment holds the records of the ancestor
 * entries whose quantized box overlaps the cell, then the cell's own entries:
 * exactly the objects a new entry of that cell must be tested against. A
 * pair is reported only in the cell that holds the low corner of the two
 * boxes' quantized intersection, so it is reported once, with no hash set
 * (docs/encoding.md has the proof). Records are stored by column so that
 * the test of one entry against its candidates runs 8 at a time (AVX2). */
#include "octree/octree.h"

#include <math.h>
#include <stdlib.h>

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#include <immintrin.h>
#define LC_HAVE_AVX2_KERNEL 1
#endif

#define LC_MAX_SEGS 24
#define LC_PREFETCH 12

typedef struct lc_seg {
    uint64_t cm;  /* Morton code of the cell at its own level */
    size_t start; /* first record of the segment */
    uint32_t level;
} lc_seg;

/* Column views of the candidate records. */
typedef struct lc_cols {
    int32_t *lo[3], *hi[3];
    uint32_t *idx;
} lc_cols;

/* The ties an AVX2 scan wrote as pairs before their exact test: their
 * places in the pair array, as offsets from pair `base` (ties_flush_avx2). */
#define LC_TIES 1024
typedef struct lc_ties {
    size_t base, n;
    int common; /* ties are common in this sweep: the scan records them with no branch */
    uint32_t pos[LC_TIES + 8]; /* room for one more block's 8 */
} lc_ties;

/* One entry being tested against its candidates. */
typedef struct lc_scan {
    lc_cols c;
    int32_t lo[3], hi[3];
    uint32_t idx;
    uint32_t s;       /* LC_SBITS - level of the entry's cell */
    int32_t cell[3];  /* the cell's integer coordinates at that level */
    const void *boxes;
    int f64;
    uint32_t split; /* lc_sweep_out's: 0, or the first object of set b */
    lc_ties *ties;  /* the sweep's (its state's) */
} lc_scan;

typedef size_t (*lc_scan_fn)(const lc_scan *sc, size_t first, size_t end, uint32_t *pairs, size_t np,
                             uint64_t *exact);

/* Each column has LC_PAD spare slots so the vector kernel may read a whole
 * vector past the last record (lanes it then ignores). */
#define LC_PAD 16
#define LC_PAIR_SLACK 16
#define LC_STRIDE(cap) ((cap) + LC_PAD)

static void cols_of(const lc_sweep_out *o, lc_cols *c)
{
    const size_t stride = LC_STRIDE(o->cand_cap);
    int a;
    for (a = 0; a < 3; a++) {
        c->lo[a] = o->cand + (size_t)a * stride;
        c->hi[a] = o->cand + (size_t)(a + 3) * stride;
    }
    c->idx = (uint32_t *)(o->cand + 6 * stride);
}

/* Grows the record columns to hold `need` records, keeping [0, used). */
static locd_status cand_reserve(lc_sweep_out *o, size_t used, size_t need)
{
    size_t cap = o->cand_cap * 2, bytes, col;
    int32_t *block;
    if (need <= o->cand_cap)
        return LOCD_OK;
    if (cap < need)
        cap = need;
    if (cap < 256)
        cap = 256;
    if (!lc_mul_size(LC_STRIDE(cap), 7 * sizeof(int32_t), &bytes))
        return lc_error(LOCD_ERR_NO_MEMORY, "candidate list of %zu records overflows size_t", cap);
    block = lc_alloc(o->alloc, bytes);
    if (!block)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate %zu bytes for candidates", bytes);
    memset(block, 0, bytes); /* padding lanes are read, never used: keep them defined */
    for (col = 0; col < 7 && used; col++)
        memcpy(block + col * LC_STRIDE(cap), o->cand + col * LC_STRIDE(o->cand_cap), used * sizeof(int32_t));
    if (o->cand)
        lc_free(o->alloc, o->cand, LC_STRIDE(o->cand_cap) * 7 * sizeof(int32_t));
    o->cand = block;
    o->cand_cap = cap;
    return LOCD_OK;
}

static void cand_put(const lc_cols *c, size_t r, const int32_t q[6], uint32_t idx)
{
    c->lo[0][r] = q[0];
    c->lo[1][r] = q[1];
    c->lo[2][r] = q[2];
    c->hi[0][r] = q[3];
    c->hi[1][r] = q[4];
    c->hi[2][r] = q[5];
    c->idx[r] = idx;
}

/* The integer coordinates of an entry's cell at shift s: the box's first or
 * second cell on each axis, as the Morton code's lowest bit per axis says. */
LC_INLINE void lc_cell_of(const int32_t q[6], uint64_t cm, uint32_t s, int32_t cell[3])
{
    cell[0] = (q[0] >> s) + (((q[0] >> s) ^ (int32_t)cm) & 1);
    cell[1] = (q[1] >> s) + (((q[1] >> s) ^ (int32_t)(cm >> 1)) & 1);
    cell[2] = (q[2] >> s) + (((q[2] >> s) ^ (int32_t)(cm >> 2)) & 1);
}

/* A dense cell's x and y ranges cut into slabs, its entries bucketed by the
 * (x slab, y slab) where each box starts: 2^bits[0] slabs on x and 2^bits[1]
 * on y, as many as the cell's population pays for (16 x 1 from
 * LC_SLAB_MIN entries, 16 x 16 from LC_YSLAB_MIN, 32 x 32 from
 * LC_FINE_MIN). Boxes starting left of (below) the cell count in the first
 * slab, so bucket order is x order up to the slab, and y order up to the
 * slab within one. */
#define LC_MAX_SLAB_BITS 5
#define LC_BUCKETS (1u << (2 * LC_MAX_SLAB_BITS))
/* Fewer entries than this: ordering a cell costs more than it saves. */
#define LC_SLAB_MIN 12
/* Entries from which y is cut too (16 x 16 buckets), and from which both
 * axes are cut finer (32 x 32). Below LC_YSLAB_MIN the extra runs of a 2-D
 * window cost more time than the candidates they save (measured on the
 * uniform scene, about 54 entries a cell: half the candidates, a quarter
 * more sweep time). */
#define LC_YSLAB_MIN 96
#define LC_FINE_MIN 768
typedef struct lc_slabs {
    int64_t origin[2]; /* the cell's low x and y */
    uint32_t shift[2]; /* log2 of a slab's width on x and y */
    uint32_t bits[2];  /* log2 of the number of slabs on x and y */
} lc_slabs;

/* The slabs of the cell with integer coordinates cell at shift s, for m entries. */
static void slabs_of(lc_slabs *sl, const int32_t cell[3], uint32_t s, size_t m)
{
    int a;
    sl->bits[0] = m >= LC_FINE_MIN ? 5u : 4u;
    sl->bits[1] = m >= LC_FINE_MIN ? 5u : m >= LC_YSLAB_MIN ? 4u : 0u;
    for (a = 0; a < 2; a++) {
        sl->origin[a] = (int64_t)cell[a] << s;
        sl->shift[a] = s > sl->bits[a] ? s - sl->bits[a] : 0;
    }
}

/* The slab of coordinate x on axis a (0: x, 1: y), clamped to the cell. */
LC_INLINE uint32_t slab_of(const lc_slabs *sl, int a, int64_t x)
{
    const int64_t top = ((int64_t)1 << sl->bits[a]) - 1;
    int64_t b = x - sl->origin[a];
    b = b < 0 ? 0 : b >> sl->shift[a];
    return (uint32_t)(b < top ? b : top);
}

/* The bucket of x slab bx and y slab by (row-major: x slab first). */
LC_INLINE uint32_t bucket_of(const lc_slabs *sl, uint32_t bx, uint32_t by)
{
    return (bx << sl->bits[1]) | by;
}

/* A dense cell's ancestor records in x order. Every own entry of a dense
 * cell meets all the records of its ancestors that overlap the cell; on
 * boxes of mixed sizes these are most of the candidates, and many of them
 * miss the entry on x alone. So when a
 * cell has LC_ANC_OWN_MIN own entries and LC_ANC_MIN ancestor records,
 * the records are copied past the cell's rows: the wide ones (x extent at
 * least half the cell's edge) first, in order, then the narrow ones by the
 * slab of the cell's x range (2^LC_ANC_SLAB_BITS slabs) where they start,
 * stable. An entry then scans the wide ones and only the narrow ones that
 * start in [lo_x - ext, hi_x] (ext: their largest x extent), one run.
 * Thresholds from the mixed scene at 3.5 pairs per box: 8/16 and 32/32
 * change its candidates by under 1% (`locd pairs`). */
#define LC_ANC_OWN_MIN 16
#define LC_ANC_MIN 32
#define LC_ANC_SLAB_BITS 6
typedef struct lc_anc {
    int on;              /* 0: the ancestors are scanned in place, in full */
    size_t wide, narrow; /* the copy: wide rows [wide, narrow), then the narrow ones */
    lc_slabs sl;         /* x slabs only (bits[1] = 0) */
    int64_t ext;         /* the narrow records' largest x extent */
    size_t start[(1u << LC_ANC_SLAB_BITS) + 1]; /* each slab's first narrow row */
} lc_anc;

/* Grows the pair buffer to `values` uint32 (two per pair), keeping the
 * `used` pairs found so far; a lent buffer is copied out, never freed. */
static locd_status pairs_reserve(lc_sweep_out *o, size_t values, size_t used)
{
    if (o->pairs_lent) {
        lc_buf own = {NULL, 0};
        locd_status st = lc_buf_reserve(o->alloc, &own, sizeof(uint32_t), values + values / 2);
        if (st)
            return st;
        if (used)
            memcpy(own.data, o->pairs.data, used * 2 * sizeof(uint32_t));
        o->pairs = own;
        o->pairs_lent = 0;
        return LOCD_OK;
    }
    return lc_buf_reserve(o->alloc, &o->pairs, sizeof(uint32_t), values);
}

void lc_sweep_out_lend(lc_sweep_out *o, uint32_t *values, size_t cap)
{
    if (!values) { /* the loan ends; an own buffer stays */
        if (o->pairs_lent) {
            o->pairs.data = NULL;
            o->pairs.cap = 0;
            o->pairs_lent = 0;
        }
        return;
    }
    if (!o->pairs_lent && o->pairs.cap >= cap)
        return; /* a scene with many pairs grew a larger buffer: keep it */
    if (!o->pairs_lent)
        lc_buf_release(o->alloc, &o->pairs, sizeof(uint32_t));
    o->pairs.data = values;
    o->pairs.cap = cap;
    o->pairs_lent = 1;
}

/* The first entry at or after p that starts a cell (p itself if it does). */
static size_t cell_start_from(const uint64_t *e, size_t count, size_t p, uint32_t ib)
{
    while (p > 0 && p < count && (e[p] >> ib) == (e[p - 1] >> ib))
        p++;
    return p;
}

/* Copies record `from` to row `to` (all seven columns). */
LC_INLINE void copy_row(const lc_cols *c, size_t from, size_t to)
{
    c->lo[0][to] = c->lo[0][from];
    c->lo[1][to] = c->lo[1][from];
    c->lo[2][to] = c->lo[2][from];
    c->hi[0][to] = c->hi[0][from];
    c->hi[1][to] = c->hi[1][from];
    c->hi[2][to] = c->hi[2][from];
    c->idx[to] = c->idx[from];
}

/* Copies the ancestor records [first, own) of the cell with integer
 * coordinates cell at shift s to rows at.. in lc_anc's order (above). */
static locd_status anc_order(lc_sweep_out *o, lc_anc *an, const int32_t cell[3], uint32_t s, size_t first,
                             size_t own, size_t at)
{
    enum { NS = 1u << LC_ANC_SLAB_BITS };
    const int64_t half = (int64_t)1 << (s ? s - 1 : 0);
    size_t fill[NS], r, wide = 0;
    int64_t ext = 0;
    uint32_t b;
    lc_cols c;
    locd_status st = cand_reserve(o, at, at + (own - first));
    if (st)
        return st;
    cols_of(o, &c);
    an->sl.bits[0] = LC_ANC_SLAB_BITS, an->sl.bits[1] = 0;
    an->sl.origin[0] = (int64_t)cell[0] << s, an->sl.origin[1] = 0;
    an->sl.shift[0] = s > LC_ANC_SLAB_BITS ? s - LC_ANC_SLAB_BITS : 0, an->sl.shift[1] = 0;
    memset(an->start, 0, sizeof an->start);
    for (r = first; r < own; r++) {
        const int64_t w = (int64_t)c.hi[0][r] - c.lo[0][r];
        if (w >= half) {
            wide++;
        } else {
            an->start[slab_of(&an->sl, 0, c.lo[0][r]) + 1]++;
            ext = w > ext ? w : ext;
        }
    }
    an->wide = at, an->narrow = at + wide, an->ext = ext;
    an->start[0] = an->narrow;
    for (b = 0; b < NS; b++)
        an->start[b + 1] += an->start[b];
    for (b = 0; b < NS; b++)
        fill[b] = an->start[b];
    for (r = first; r < own; r++) {
        const int64_t w = (int64_t)c.hi[0][r] - c.lo[0][r];
        copy_row(&c, r, w >= half ? at++ : fill[slab_of(&an->sl, 0, c.lo[0][r])]++);
    }
    an->on = 1;
    return LOCD_OK;
}

typedef size_t (*lc_filter_fn)(const lc_cols *c, size_t from, size_t to, const int32_t lo[3], const int32_t hi[3],
                               size_t w);

static size_t filter_scalar(const lc_cols *c, size_t from, size_t to, const int32_t lo[3], const int32_t hi[3],
                            size_t w)
{
    size_t r;
    for (r = from; r < to; r++)
        if (c->lo[0][r] <= hi[0] && c->hi[0][r] >= lo[0] && c->lo[1][r] <= hi[1] && c->hi[1][r] >= lo[1] &&
            c->lo[2][r] <= hi[2] && c->hi[2][r] >= lo[2])
            copy_row(c, r, w++);
    return w;
}

#ifdef LC_HAVE_AVX2_KERNEL
/* The 32-bit lanes that gather the lanes set in an 8-bit mask to the
 * front, in order: byte k of entry m is the k-th lane set in m (a compress
 * for AVX2, which has none; generated, one entry per mask). */
static const uint64_t lc_compress8[256] = {
    0x0000000000000000ull, 0x0000000000000000ull, 0x0000000000000001ull, 0x0000000000000100ull,
    0x0000000000000002ull, 0x0000000000000200ull, 0x0000000000000201ull, 0x0000000000020100ull,
    0x0000000000000003ull, 0x0000000000000300ull, 0x0000000000000301ull, 0x0000000000030100ull,
    0x0000000000000302ull, 0x0000000000030200ull, 0x0000000000030201ull, 0x0000000003020100ull,
    0x0000000000000004ull, 0x0000000000000400ull, 0x0000000000000401ull, 0x0000000000040100ull,
    0x0000000000000402ull, 0x0000000000040200ull, 0x0000000000040201ull, 0x0000000004020100ull,
    0x0000000000000403ull, 0x0000000000040300ull, 0x0000000000040301ull, 0x0000000004030100ull,
    0x0000000000040302ull, 0x0000000004030200ull, 0x0000000004030201ull, 0x0000000403020100ull,
    0x0000000000000005ull, 0x0000000000000500ull, 0x0000000000000501ull, 0x0000000000050100ull,
    0x0000000000000502ull, 0x0000000000050200ull, 0x0000000000050201ull, 0x0000000005020100ull,
    0x0000000000000503ull, 0x0000000000050300ull, 0x0000000000050301ull, 0x0000000005030100ull,
    0x0000000000050302ull, 0x0000000005030200ull, 0x0000000005030201ull, 0x0000000503020100ull,
    0x0000000000000504ull, 0x0000000000050400ull, 0x0000000000050401ull, 0x0000000005040100ull,
    0x0000000000050402ull, 0x0000000005040200ull, 0x0000000005040201ull, 0x0000000504020100ull,
    0x0000000000050403ull, 0x0000000005040300ull, 0x0000000005040301ull, 0x0000000504030100ull,
    0x0000000005040302ull, 0x0000000504030200ull, 0x0000000504030201ull, 0x0000050403020100ull,
    0x0000000000000006ull, 0x0000000000000600ull, 0x0000000000000601ull, 0x0000000000060100ull,
    0x0000000000000602ull, 0x0000000000060200ull, 0x0000000000060201ull, 0x0000000006020100ull,
    0x0000000000000603ull, 0x0000000000060300ull, 0x0000000000060301ull, 0x0000000006030100ull,
    0x0000000000060302ull, 0x0000000006030200ull, 0x0000000006030201ull, 0x0000000603020100ull,
    0x0000000000000604ull, 0x0000000000060400ull, 0x0000000000060401ull, 0x0000000006040100ull,
    0x0000000000060402ull, 0x0000000006040200ull, 0x0000000006040201ull, 0x0000000604020100ull,
    0x0000000000060403ull, 0x0000000006040300ull, 0x0000000006040301ull, 0x0000000604030100ull,
    0x0000000006040302ull, 0x0000000604030200ull, 0x0000000604030201ull, 0x0000060403020100ull,
    0x0000000000000605ull, 0x0000000000060500ull, 0x0000000000060501ull, 0x0000000006050100ull,
    0x0000000000060502ull, 0x0000000006050200ull, 0x0000000006050201ull, 0x0000000605020100ull,
    0x0000000000060503ull, 0x0000000006050300ull, 0x0000000006050301ull, 0x0000000605030100ull,
    0x0000000006050302ull, 0x0000000605030200ull, 0x0000000605030201ull, 0x0000060503020100ull,
    0x0000000000060504ull, 0x0000000006050400ull, 0x0000000006050401ull, 0x0000000605040100ull,
    0x0000000006050402ull, 0x0000000605040200ull, 0x0000000605040201ull, 0x0000060504020100ull,
    0x0000000006050403ull, 0x0000000605040300ull, 0x0000000605040301ull, 0x0000060504030100ull,
    0x0000000605040302ull, 0x0000060504030200ull, 0x0000060504030201ull, 0x0006050403020100ull,
    0x0000000000000007ull, 0x0000000000000700ull, 0x0000000000000701ull, 0x0000000000070100ull,
    0x0000000000000702ull, 0x0000000000070200ull, 0x0000000000070201ull, 0x0000000007020100ull,
    0x0000000000000703ull, 0x0000000000070300ull, 0x0000000000070301ull, 0x0000000007030100ull,
    0x0000000000070302ull, 0x0000000007030200ull, 0x0000000007030201ull, 0x0000000703020100ull,
    0x0000000000000704ull, 0x0000000000070400ull, 0x0000000000070401ull, 0x0000000007040100ull,
    0x0000000000070402ull, 0x0000000007040200ull, 0x0000000007040201ull, 0x0000000704020100ull,
    0x0000000000070403ull, 0x0000000007040300ull, 0x0000000007040301ull, 0x0000000704030100ull,
    0x0000000007040302ull, 0x0000000704030200ull, 0x0000000704030201ull, 0x0000070403020100ull,
    0x0000000000000705ull, 0x0000000000070500ull, 0x0000000000070501ull, 0x0000000007050100ull,
    0x0000000000070502ull, 0x0000000007050200ull, 0x0000000007050201ull, 0x0000000705020100ull,
    0x0000000000070503ull, 0x0000000007050300ull, 0x0000000007050301ull, 0x0000000705030100ull,
    0x0000000007050302ull, 0x0000000705030200ull, 0x0000000705030201ull, 0x0000070503020100ull,
    0x0000000000070504ull, 0x0000000007050400ull, 0x0000000007050401ull, 0x0000000705040100ull,
    0x0000000007050402ull, 0x0000000705040200ull, 0x0000000705040201ull, 0x0000070504020100ull,
    0x0000000007050403ull, 0x0000000705040300ull, 0x0000000705040301ull, 0x0000070504030100ull,
    0x0000000705040302ull, 0x0000070504030200ull, 0x0000070504030201ull, 0x0007050403020100ull,
    0x0000000000000706ull, 0x0000000000070600ull, 0x0000000000070601ull, 0x0000000007060100ull,
    0x0000000000070602ull, 0x0000000007060200ull, 0x0000000007060201ull, 0x0000000706020100ull,
    0x0000000000070603ull, 0x0000000007060300ull, 0x0000000007060301ull, 0x0000000706030100ull,
    0x0000000007060302ull, 0x0000000706030200ull, 0x0000000706030201ull, 0x0000070603020100ull,
    0x0000000000070604ull, 0x0000000007060400ull, 0x0000000007060401ull, 0x0000000706040100ull,
    0x0000000007060402ull, 0x0000000706040200ull, 0x0000000706040201ull, 0x0000070604020100ull,
    0x0000000007060403ull, 0x0000000706040300ull, 0x0000000706040301ull, 0x0000070604030100ull,
    0x0000000706040302ull, 0x0000070604030200ull, 0x0000070604030201ull, 0x0007060403020100ull,
    0x0000000000070605ull, 0x0000000007060500ull, 0x0000000007060501ull, 0x0000000706050100ull,
    0x0000000007060502ull, 0x0000000706050200ull, 0x0000000706050201ull, 0x0000070605020100ull,
    0x0000000007060503ull, 0x0000000706050300ull, 0x0000000706050301ull, 0x0000070605030100ull,
    0x0000000706050302ull, 0x0000070605030200ull, 0x0000070605030201ull, 0x0007060503020100ull,
    0x0000000007060504ull, 0x0000000706050400ull, 0x0000000706050401ull, 0x0000070605040100ull,
    0x0000000706050402ull, 0x0000070605040200ull, 0x0000070605040201ull, 0x0007060504020100ull,
    0x0000000706050403ull, 0x0000070605040300ull, 0x0000070605040301ull, 0x0007060504030100ull,
    0x0000070605040302ull, 0x0007060504030200ull, 0x0007060504030201ull, 0x0706050403020100ull,
};

/* Byte k of entry m: how many lanes below lane k are set in m, the place
 * of lane k's pair among those a block writes (store_pairs_avx2). */
static const uint64_t lc_rank8[256] = {
    0x0000000000000000ull, 0x0101010101010100ull, 0x0101010101010000ull, 0x0202020202020100ull,
    0x0101010101000000ull, 0x0202020202010100ull, 0x0202020202010000ull, 0x0303030303020100ull,
    0x0101010100000000ull, 0x0202020201010100ull, 0x0202020201010000ull, 0x0303030302020100ull,
    0x0202020201000000ull, 0x0303030302010100ull, 0x0303030302010000ull, 0x0404040403020100ull,
    0x0101010000000000ull, 0x0202020101010100ull, 0x0202020101010000ull, 0x0303030202020100ull,
    0x0202020101000000ull, 0x0303030202010100ull, 0x0303030202010000ull, 0x0404040303020100ull,
    0x0202020100000000ull, 0x0303030201010100ull, 0x0303030201010000ull, 0x0404040302020100ull,
    0x0303030201000000ull, 0x0404040302010100ull, 0x0404040302010000ull, 0x0505050403020100ull,
    0x0101000000000000ull, 0x0202010101010100ull, 0x0202010101010000ull, 0x0303020202020100ull,
    0x0202010101000000ull, 0x0303020202010100ull, 0x0303020202010000ull, 0x0404030303020100ull,
    0x0202010100000000ull, 0x0303020201010100ull, 0x0303020201010000ull, 0x0404030302020100ull,
    0x0303020201000000ull, 0x0404030302010100ull, 0x0404030302010000ull, 0x0505040403020100ull,
    0x0202010000000000ull, 0x0303020101010100ull, 0x0303020101010000ull, 0x0404030202020100ull,
    0x0303020101000000ull, 0x0404030202010100ull, 0x0404030202010000ull, 0x0505040303020100ull,
    0x0303020100000000ull, 0x0404030201010100ull, 0x0404030201010000ull, 0x0505040302020100ull,
    0x0404030201000000ull, 0x0505040302010100ull, 0x0505040302010000ull, 0x0606050403020100ull,
    0x0100000000000000ull, 0x0201010101010100ull, 0x0201010101010000ull, 0x0302020202020100ull,
    0x0201010101000000ull, 0x0302020202010100ull, 0x0302020202010000ull, 0x0403030303020100ull,
    0x0201010100000000ull, 0x0302020201010100ull, 0x0302020201010000ull, 0x0403030302020100ull,
    0x0302020201000000ull, 0x0403030302010100ull, 0x0403030302010000ull, 0x0504040403020100ull,
    0x0201010000000000ull, 0x0302020101010100ull, 0x0302020101010000ull, 0x0403030202020100ull,
    0x0302020101000000ull, 0x0403030202010100ull, 0x0403030202010000ull, 0x0504040303020100ull,
    0x0302020100000000ull, 0x0403030201010100ull, 0x0403030201010000ull, 0x0504040302020100ull,
    0x0403030201000000ull, 0x0504040302010100ull, 0x0504040302010000ull, 0x0605050403020100ull,
    0x0201000000000000ull, 0x0302010101010100ull, 0x0302010101010000ull, 0x0403020202020100ull,
    0x0302010101000000ull, 0x0403020202010100ull, 0x0403020202010000ull, 0x0504030303020100ull,
    0x0302010100000000ull, 0x0403020201010100ull, 0x0403020201010000ull, 0x0504030302020100ull,
    0x0403020201000000ull, 0x0504030302010100ull, 0x0504030302010000ull, 0x0605040403020100ull,
    0x0302010000000000ull, 0x0403020101010100ull, 0x0403020101010000ull, 0x0504030202020100ull,
    0x0403020101000000ull, 0x0504030202010100ull, 0x0504030202010000ull, 0x0605040303020100ull,
    0x0403020100000000ull, 0x0504030201010100ull, 0x0504030201010000ull, 0x0605040302020100ull,
    0x0504030201000000ull, 0x0605040302010100ull, 0x0605040302010000ull, 0x0706050403020100ull,
    0x0000000000000000ull, 0x0101010101010100ull, 0x0101010101010000ull, 0x0202020202020100ull,
    0x0101010101000000ull, 0x0202020202010100ull, 0x0202020202010000ull, 0x0303030303020100ull,
    0x0101010100000000ull, 0x0202020201010100ull, 0x0202020201010000ull, 0x0303030302020100ull,
    0x0202020201000000ull, 0x0303030302010100ull, 0x0303030302010000ull, 0x0404040403020100ull,
    0x0101010000000000ull, 0x0202020101010100ull, 0x0202020101010000ull, 0x0303030202020100ull,
    0x0202020101000000ull, 0x0303030202010100ull, 0x0303030202010000ull, 0x0404040303020100ull,
    0x0202020100000000ull, 0x0303030201010100ull, 0x0303030201010000ull, 0x0404040302020100ull,
    0x0303030201000000ull, 0x0404040302010100ull, 0x0404040302010000ull, 0x0505050403020100ull,
    0x0101000000000000ull, 0x0202010101010100ull, 0x0202010101010000ull, 0x0303020202020100ull,
    0x0202010101000000ull, 0x0303020202010100ull, 0x0303020202010000ull, 0x0404030303020100ull,
    0x0202010100000000ull, 0x0303020201010100ull, 0x0303020201010000ull, 0x0404030302020100ull,
    0x0303020201000000ull, 0x0404030302010100ull, 0x0404030302010000ull, 0x0505040403020100ull,
    0x0202010000000000ull, 0x0303020101010100ull, 0x0303020101010000ull, 0x0404030202020100ull,
    0x0303020101000000ull, 0x0404030202010100ull, 0x0404030202010000ull, 0x0505040303020100ull,
    0x0303020100000000ull, 0x0404030201010100ull, 0x0404030201010000ull, 0x0505040302020100ull,
    0x0404030201000000ull, 0x0505040302010100ull, 0x0505040302010000ull, 0x0606050403020100ull,
    0x0100000000000000ull, 0x0201010101010100ull, 0x0201010101010000ull, 0x0302020202020100ull,
    0x0201010101000000ull, 0x0302020202010100ull, 0x0302020202010000ull, 0x0403030303020100ull,
    0x0201010100000000ull, 0x0302020201010100ull, 0x0302020201010000ull, 0x0403030302020100ull,
    0x0302020201000000ull, 0x0403030302010100ull, 0x0403030302010000ull, 0x0504040403020100ull,
    0x0201010000000000ull, 0x0302020101010100ull, 0x0302020101010000ull, 0x0403030202020100ull,
    0x0302020101000000ull, 0x0403030202010100ull, 0x0403030202010000ull, 0x0504040303020100ull,
    0x0302020100000000ull, 0x0403030201010100ull, 0x0403030201010000ull, 0x0504040302020100ull,
    0x0403030201000000ull, 0x0504040302010100ull, 0x0504040302010000ull, 0x0605050403020100ull,
    0x0201000000000000ull, 0x0302010101010100ull, 0x0302010101010000ull, 0x0403020202020100ull,
    0x0302010101000000ull, 0x0403020202010100ull, 0x0403020202010000ull, 0x0504030303020100ull,
    0x0302010100000000ull, 0x0403020201010100ull, 0x0403020201010000ull, 0x0504030302020100ull,
    0x0403020201000000ull, 0x0504030302010100ull, 0x0504030302010000ull, 0x0605040403020100ull,
    0x0302010000000000ull, 0x0403020101010100ull, 0x0403020101010000ull, 0x0504030202020100ull,
    0x0403020101000000ull, 0x0504030202010100ull, 0x0504030202010000ull, 0x0605040303020100ull,
    0x0403020100000000ull, 0x0504030201010100ull, 0x0504030201010000ull, 0x0605040302020100ull,
    0x0504030201000000ull, 0x0605040302010100ull, 0x0605040302010000ull, 0x0706050403020100ull,
};

/* Lanes of records r..r+7 whose box overlaps [lo, hi] (closed). */
__attribute__((target("avx2"))) LC_INLINE unsigned overlap8(const lc_cols *c, size_t r, __m256i lo0, __m256i lo1,
                                                            __m256i lo2, __m256i hi0, __m256i hi1, __m256i hi2)
{
    __m256i rej = _mm256_cmpgt_epi32(lo0, _mm256_loadu_si256((const __m256i *)(c->hi[0] + r)));
    rej = _mm256_or_si256(rej, _mm256_cmpgt_epi32(_mm256_loadu_si256((const __m256i *)(c->lo[0] + r)), hi0));
    rej = _mm256_or_si256(rej, _mm256_cmpgt_epi32(lo1, _mm256_loadu_si256((const __m256i *)(c->hi[1] + r))));
    rej = _mm256_or_si256(rej, _mm256_cmpgt_epi32(_mm256_loadu_si256((const __m256i *)(c->lo[1] + r)), hi1));
    rej = _mm256_or_si256(rej, _mm256_cmpgt_epi32(lo2, _mm256_loadu_si256((const __m256i *)(c->hi[2] + r))));
    rej = _mm256_or_si256(rej, _mm256_cmpgt_epi32(_mm256_loadu_si256((const __m256i *)(c->lo[2] + r)), hi2));
    return ~(unsigned)_mm256_movemask_ps(_mm256_castsi256_ps(rej)) & 0xffu;
}

/* Writes the lanes of column vector v set in m at col + w, in order (one
 * full-vector store: the column has room for it, see filter_avx2). */
__attribute__((target("avx2"))) LC_INLINE void compress_store8(int32_t *col, size_t w, __m256i v, __m256i perm)
{
    _mm256_storeu_si256((__m256i *)(col + w), _mm256_permutevar8x32_epi32(v, perm));
}

/* The records of [from, to) whose box overlaps [lo, hi], copied in order to
 * rows w.. (w >= to: the copies never overwrite a row still to be read).
 * Each block of 8 is compressed with one permutation and one full-vector
 * store per column (the columns keep LC_PAD spare rows past the reserved
 * ones for the last store's extra lanes), not one lane at a time: on the
 * mixed35 scene, whose big boxes make long ancestor lists, a call filters
 * 20.8 million records and keeps 4.3 million, and perf put the filter at a
 * fifth of the call. */
__attribute__((target("avx2"))) static size_t filter_avx2(const lc_cols *c, size_t from, size_t to,
                                                          const int32_t lo[3], const int32_t hi[3], size_t w)
{
    const __m256i lo0 = _mm256_set1_epi32(lo[0]), lo1 = _mm256_set1_epi32(lo[1]), lo2 = _mm256_set1_epi32(lo[2]);
    const __m256i hi0 = _mm256_set1_epi32(hi[0]), hi1 = _mm256_set1_epi32(hi[1]), hi2 = _mm256_set1_epi32(hi[2]);
    size_t r;
    /* Reads may run up to 7 records past `to` (padding or rows this call
       already wrote): those lanes are masked off. */
    for (r = from; r < to; r += 8) {
        unsigned m = overlap8(c, r, lo0, lo1, lo2, hi0, hi1, hi2);
        __m256i perm;
        int a;
        if (to - r < 8)
            m &= (1u << (to - r)) - 1u;
        if (!m)
            continue;
        perm = _mm256_cvtepu8_epi32(_mm_loadl_epi64((const __m128i *)(lc_compress8 + m)));
        for (a = 0; a < 3; a++) {
            compress_store8(c->lo[a], w, _mm256_loadu_si256((const __m256i *)(c->lo[a] + r)), perm);
            compress_store8(c->hi[a], w, _mm256_loadu_si256((const __m256i *)(c->hi[a] + r)), perm);
        }
        compress_store8((int32_t *)c->idx, w, _mm256_loadu_si256((const __m256i *)(c->idx + r)), perm);
        w += (size_t)__builtin_popcount(m);
    }
    return w;
}
#endif

/* Pushes the segment of cell `cell` (integer coordinates) at `level`: the
 * records of the current top segment that overlap the cell. */
static locd_status push_filtered(const locd_grid *g, lc_sweep_out *o, lc_seg *segs, uint32_t *nseg, size_t *ncand,
                                 uint64_t pm, uint32_t level, const int32_t cell[3], size_t extra)
{
    const uint32_t s = LC_SBITS - level;
    size_t start = *ncand, pstart = *nseg ? segs[*nseg - 1].start : start;
    segs[*nseg].cm = pm >> (3u * (g->depth - level));
    segs[*nseg].start = start;
    segs[*nseg].level = level;
    (*nseg)++;
    if (start + (start - pstart) + extra > o->cand_cap) {
        locd_status st = cand_reserve(o, start, start + (start - pstart) + extra);
        if (st)
            return st;
    }
    if (start > pstart) {
        int32_t clo[3], chi[3];
        lc_cols c;
        int a;
        cols_of(o, &c);
        for (a = 0; a < 3; a++) {
            clo[a] = (int32_t)((uint32_t)cell[a] << s);
            chi[a] = (int32_t)(((int64_t)clo[a] + ((int64_t)1 << s)) - 1);
        }
        *ncand = ((lc_filter_fn)o->filter)(&c, pstart, start, clo, chi, start);
    }
    return LOCD_OK;
}

/* When the top segment is more than one level above a cell at `level` and
 * long, gives the cell's parent a segment, so that sibling cells filter (or
 * scan) a short list instead of the long one; the records, and their
 * order, are the same either way. */
#define LC_FILTER_STEP_MIN 16
static locd_status open_parent(const locd_grid *g, lc_sweep_out *o, lc_seg *segs, uint32_t *nseg, size_t *ncand,
                               uint64_t pm, uint32_t level, const int32_t cell[3])
{
    if (*nseg && segs[*nseg - 1].level + 1 < level && *ncand - segs[*nseg - 1].start >= LC_FILTER_STEP_MIN) {
        const int32_t parent[3] = {cell[0] >> 1, cell[1] >> 1, cell[2] >> 1};
        return push_filtered(g, o, segs, nseg, ncand, pm, level - 1, parent, 0);
    }
    return LOCD_OK;
}

/* Opens the segment of cell (pm, level, cell) under the current top segment
 * (after its parent's, see open_parent) and reserves room for `extra` more
 * records. */
static locd_status open_segment(const locd_grid *g, lc_sweep_out *o, lc_seg *segs, uint32_t *nseg, size_t *ncand,
                                uint64_t pm, uint32_t level, const int32_t cell[3], size_t extra)
{
    locd_status st = open_parent(g, o, segs, nseg, ncand, pm, level, cell);
    if (st)
        return st;
    return push_filtered(g, o, segs, nseg, ncand, pm, level, cell, extra);
}

/* Whether the cell of key `next` lies strictly inside cell (pm, level). */
LC_INLINE int lc_descends(uint64_t next, uint64_t pm, uint32_t level, uint32_t depth)
{
    const uint32_t shift = 3u * (depth - level);
    return (uint32_t)(next & ((1u << LC_LEVEL_BITS) - 1)) > level &&
           ((next >> LC_LEVEL_BITS) >> shift) == (pm >> shift);
}

/* The closed box test on the original coordinates, for the scalar and
 * NEON scans (emit_if_canonical; the AVX2 loops use exact_meets_avx2, one
 * vector compare). Inlined, so it is compiled for the caller's target:
 * called from an AVX2 or AVX-512 loop as a separate SSE-encoded function
 * (before those loops had a test of their own), it ran with the
 * vector registers' upper halves dirty (no vzeroupper there), and the
 * kernels spent more time in it than in their scans. On a lattice of
 * touching cubes, where nearly every pair needs it, LOCD_KERNEL=avx2 took
 * 5.5 times as long as the scalar kernel (docs/benchmarks.md, "The exact
 * test inside the kernels"). */
LC_INLINE int exact_overlap(const void *boxes, int f64, uint32_t i, uint32_t j)
{
    if (f64) {
        const double *a = (const double *)boxes + 6 * (size_t)i, *b = (const double *)boxes + 6 * (size_t)j;
        return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
    } else {
        const float *a = (const float *)boxes + 6 * (size_t)i, *b = (const float *)boxes + 6 * (size_t)j;
        return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
    }
}

/* Candidate r passed the quantized reject test: report it if this cell is
 * the pair's canonical cell and the boxes really overlap. */
LC_INLINE size_t emit_if_canonical(const lc_scan *sc, size_t r, uint32_t *pairs, size_t np, uint64_t *exact)
{
    const int32_t l0 = sc->c.lo[0][r], l1 = sc->c.lo[1][r], l2 = sc->c.lo[2][r];
    const int32_t h0 = sc->c.hi[0][r], h1 = sc->c.hi[1][r], h2 = sc->c.hi[2][r];
    const int32_t m0 = l0 > sc->lo[0] ? l0 : sc->lo[0], m1 = l1 > sc->lo[1] ? l1 : sc->lo[1],
                  m2 = l2 > sc->lo[2] ? l2 : sc->lo[2];
    const uint32_t j = sc->c.idx[r];
    if (sc->split && (j < sc->split) == (sc->idx < sc->split))
        return np; /* two sets: both objects in the same one */
    if (((m0 >> sc->s) != sc->cell[0]) | ((m1 >> sc->s) != sc->cell[1]) | ((m2 >> sc->s) != sc->cell[2]))
        return np; /* reported in another cell */
    /* Strictly inside each other's quantized range: the quantization is
       monotone, so the boxes overlap. Equal ends need the exact test. */
    if (!((h0 > sc->lo[0]) & (sc->hi[0] > l0) & (h1 > sc->lo[1]) & (sc->hi[1] > l1) & (h2 > sc->lo[2]) &
          (sc->hi[2] > l2))) {
        ++*exact;
        if (!exact_overlap(sc->boxes, sc->f64, sc->idx, j))
            return np;
    }
    pairs[2 * np] = j < sc->idx ? j : sc->idx;
    pairs[2 * np + 1] = j < sc->idx ? sc->idx : j;
    return np + 1;
}

static size_t scan_scalar(const lc_scan *sc, size_t first, size_t end, uint32_t *pairs, size_t np, uint64_t *exact)
{
    size_t r;
    for (r = first; r < end; r++) {
        if ((sc->c.hi[0][r] < sc->lo[0]) | (sc->hi[0] < sc->c.lo[0][r]) | (sc->c.hi[1][r] < sc->lo[1]) |
            (sc->hi[1] < sc->c.lo[1][r]) | (sc->c.hi[2][r] < sc->lo[2]) | (sc->hi[2] < sc->c.lo[2][r]))
            continue;
        np = emit_if_canonical(sc, r, pairs, np, exact);
    }
    return np;
}

#ifdef LC_HAVE_AVX2_KERNEL
#define LC_AVX2 __attribute__((target("avx2")))

/* The 32-bit lanes that gather the 64-bit lanes set in a 4-bit mask to
 * the front, in order (AVX2 has no compress). */
static const int32_t lc_compress4[16][8] = {
    {0, 1, 0, 1, 0, 1, 0, 1}, {0, 1, 0, 1, 0, 1, 0, 1}, {2, 3, 0, 1, 0, 1, 0, 1}, {0, 1, 2, 3, 0, 1, 0, 1},
    {4, 5, 0, 1, 0, 1, 0, 1}, {0, 1, 4, 5, 0, 1, 0, 1}, {2, 3, 4, 5, 0, 1, 0, 1}, {0, 1, 2, 3, 4, 5, 0, 1},
    {6, 7, 0, 1, 0, 1, 0, 1}, {0, 1, 6, 7, 0, 1, 0, 1}, {2, 3, 6, 7, 0, 1, 0, 1}, {0, 1, 2, 3, 6, 7, 0, 1},
    {4, 5, 6, 7, 0, 1, 0, 1}, {0, 1, 4, 5, 6, 7, 0, 1}, {2, 3, 4, 5, 6, 7, 0, 1}, {0, 1, 2, 3, 4, 5, 6, 7},
};

/* Writes the pairs (min, max) of object me (in every lane of mev) and the
 * objects in J's lanes set in m, in lane order, at pairs[np..]: two
 * full-vector stores (the pair buffer keeps LC_PAIR_SLACK spare pairs), no
 * branch on the lanes. Returns the new count. */
LC_AVX2 LC_INLINE size_t store_pairs_avx2(uint32_t *pairs, size_t np, __m256i J, __m256i mev, unsigned m)
{
    const __m256i a = _mm256_min_epu32(J, mev), b = _mm256_max_epu32(J, mev);
    /* (a, b) interleaved: lanes 0 1 4 5 in lo, 2 3 6 7 in hi; then 0-3 and 4-7 */
    const __m256i lo = _mm256_unpacklo_epi32(a, b), hi = _mm256_unpackhi_epi32(a, b);
    const __m256i p0 = _mm256_permute2x128_si256(lo, hi, 0x20), p1 = _mm256_permute2x128_si256(lo, hi, 0x31);
    const unsigned m0 = m & 15u, m1 = m >> 4;
    _mm256_storeu_si256((__m256i *)(pairs + 2 * np),
                        _mm256_permutevar8x32_epi32(p0, _mm256_loadu_si256((const __m256i *)lc_compress4[m0])));
    np += (size_t)__builtin_popcount(m0);
    _mm256_storeu_si256((__m256i *)(pairs + 2 * np),
                        _mm256_permutevar8x32_epi32(p1, _mm256_loadu_si256((const __m256i *)lc_compress4[m1])));
    return np + (size_t)__builtin_popcount(m1);
}

/* The exact closed test of object me's box against others', a few
 * instructions a candidate: with a = me's box and b the other's, the six
 * conditions b_lo <= a_hi and -b_hi <= -a_lo as one vector compare (negation
 * is exact, and -0 compares equal to 0 as 0 does to -0). ref holds
 * (a_hi, -a_lo) and +inf in the spare lanes, where b reads 0. A real
 * mesh's neighbours share vertices, so their boxes touch and most of their
 * pairs need this test: a scalar test behind a branch per comparison, and
 * a branch on the precision, took a sixth of the sweep on a terrain mesh. */
typedef struct lc_exact_ref {
    __m256 f;          /* float boxes */
    __m256d d[2];      /* double boxes: lanes 0-3, 4-7 */
} lc_exact_ref;

LC_AVX2 LC_INLINE void exact_ref_avx2(lc_exact_ref *ref, const void *boxes, int f64, uint32_t me)
{
    if (f64) {
        const double *a = (const double *)boxes + 6 * (size_t)me;
        ref->d[0] = _mm256_setr_pd(a[3], a[4], a[5], -a[0]);
        ref->d[1] = _mm256_setr_pd(-a[1], -a[2], HUGE_VAL, HUGE_VAL);
    } else {
        const float *a = (const float *)boxes + 6 * (size_t)me;
        ref->f = _mm256_setr_ps(a[3], a[4], a[5], -a[0], -a[1], -a[2], HUGE_VALF, HUGE_VALF);
    }
}

/* Whether object j's box meets the box of ref (exact_ref_avx2). */
LC_AVX2 LC_INLINE int exact_meets_avx2(const lc_exact_ref *ref, const void *boxes, int f64, uint32_t j)
{
    if (f64) {
        const double *b = (const double *)boxes + 6 * (size_t)j;
        const __m256d neg3 = _mm256_castsi256_pd(_mm256_setr_epi64x(0, 0, 0, INT64_MIN));
        const __m256d neg01 = _mm256_castsi256_pd(_mm256_setr_epi64x(INT64_MIN, INT64_MIN, 0, 0));
        /* b[4], b[5] only: the box may be the array's last */
        const __m256d lo = _mm256_xor_pd(_mm256_loadu_pd(b), neg3),
                      hi = _mm256_xor_pd(_mm256_maskload_pd(b + 4, _mm256_setr_epi64x(-1, -1, 0, 0)), neg01);
        return _mm256_movemask_pd(_mm256_and_pd(_mm256_cmp_pd(lo, ref->d[0], _CMP_LE_OQ),
                                                _mm256_cmp_pd(hi, ref->d[1], _CMP_LE_OQ))) == 0xf;
    } else {
        const float *b = (const float *)boxes + 6 * (size_t)j;
        const __m256 neg = _mm256_castsi256_ps(_mm256_setr_epi32(0, 0, 0, INT32_MIN, INT32_MIN, INT32_MIN, 0, 0));
        const __m256 v = _mm256_xor_ps(_mm256_maskload_ps(b, _mm256_setr_epi32(-1, -1, -1, -1, -1, -1, 0, 0)), neg);
        return _mm256_movemask_ps(_mm256_cmp_ps(v, ref->f, _CMP_LE_OQ)) == 0xff;
    }
}

/* Whether the boxes of objects i and j meet: float boxes with one vector
 * compare of (lo_i, lo_j) against (hi_j, hi_i), a few percent faster on
 * the meshes' ties than exact_meets_avx2 with i's box as the reference,
 * which double boxes take. */
LC_AVX2 LC_INLINE int boxes_meet_avx2(const void *boxes, int f64, uint32_t i, uint32_t j)
{
    const __m256i six = _mm256_setr_epi32(-1, -1, -1, -1, -1, -1, 0, 0);
    __m256 a, b, lo, hi;
    if (f64) {
        lc_exact_ref ref;
        exact_ref_avx2(&ref, boxes, f64, i);
        return exact_meets_avx2(&ref, boxes, f64, j);
    }
    a = _mm256_maskload_ps((const float *)boxes + 6 * (size_t)i, six);
    b = _mm256_maskload_ps((const float *)boxes + 6 * (size_t)j, six);
    b = _mm256_permutevar8x32_ps(b, _mm256_setr_epi32(3, 4, 5, 0, 1, 2, 6, 7)); /* hi_j, lo_j */
    lo = _mm256_blend_ps(a, b, 0x38), hi = _mm256_blend_ps(b, a, 0x38);
    return (_mm256_movemask_ps(_mm256_cmp_ps(lo, hi, _CMP_LE_OQ)) & 0x3f) == 0x3f;
}

/* Tests the ties written as pairs (t), drops the pairs whose boxes miss
 * and returns the new count. Dropping leaves the others in order, so the
 * pairs are those, in the order, that a test of each tie where it was
 * found gives (the scalar kernel's: its scans and NEON's test a tie where
 * they find it, so nothing waits in their sweeps). A real mesh's
 * neighbours share vertices, so most of its pairs tie, and nearly all of
 * them meet: tested where found, behind a branch per block of 8 that went
 * either way with no pattern, they took half of the sweep on the triangle
 * meshes (bench/results/kernels_notes.md, "Ties tested after their pairs"). */
LC_AVX2 LC_INLINE size_t ties_flush_avx2(lc_ties *t, const void *boxes, int f64, uint32_t *pairs, size_t np,
                                         uint64_t *exact)
{
    size_t k, f, nf = 0, w;
    *exact += t->n;
    for (k = 0; k < t->n; k++) { /* the misses' offsets to the front of pos */
        const size_t p = t->base + t->pos[k];
        const int met = boxes_meet_avx2(boxes, f64, pairs[2 * p], pairs[2 * p + 1]);
        t->pos[nf] = t->pos[k];
        nf += (size_t)!met;
    }
    if (nf) { /* close the gaps */
        w = t->base + t->pos[0];
        for (f = 0; f < nf; f++) {
            const size_t from = t->base + t->pos[f] + 1, to = f + 1 < nf ? t->base + t->pos[f + 1] : np;
            memmove(pairs + 2 * w, pairs + 2 * from, (to - from) * 2 * sizeof *pairs);
            w += to - from;
        }
        np = w;
    }
    t->n = 0;
    t->base = np;
    return np;
}

/* Clears the lanes of `weak` in m whose objects' boxes miss me's (the
 * exact test of quantized ends that are equal); counts the tests. */
LC_AVX2 LC_INLINE unsigned exact_lanes_avx2(const lc_scan *sc, int f64, const uint32_t *J, unsigned m, unsigned weak,
                                            uint64_t *exact)
{
    lc_exact_ref ref;
    exact_ref_avx2(&ref, sc->boxes, f64, sc->idx);
    *exact += (uint64_t)__builtin_popcount(weak);
    for (; weak; weak &= weak - 1) {
        const unsigned lane = (unsigned)__builtin_ctz(weak);
        m &= ~((unsigned)!exact_meets_avx2(&ref, sc->boxes, f64, J[lane]) << lane);
    }
    return m;
}

/* Inlined into the AVX2 main loop (sweep_range_*_avx2), whose runs of
 * candidates are short, with the input precision f64 a constant there. */
LC_AVX2 LC_INLINE size_t scan_avx2_of(const lc_scan *sc, size_t first, size_t end, uint32_t *pairs, size_t np,
                                      uint64_t *exact, int f64)
{
    /* The columns in locals: read through sc in the loop, they would be
       reloaded from memory on every step. */
    const int32_t *const X0 = sc->c.lo[0], *const Y0 = sc->c.lo[1], *const Z0 = sc->c.lo[2];
    const int32_t *const X1 = sc->c.hi[0], *const Y1 = sc->c.hi[1], *const Z1 = sc->c.hi[2];
    const uint32_t *const J = sc->c.idx;
    const uint32_t me = sc->idx, split = sc->split;
    const __m256i lo0 = _mm256_set1_epi32(sc->lo[0]), lo1 = _mm256_set1_epi32(sc->lo[1]),
                  lo2 = _mm256_set1_epi32(sc->lo[2]);
    const __m256i hi0 = _mm256_set1_epi32(sc->hi[0]), hi1 = _mm256_set1_epi32(sc->hi[1]),
                  hi2 = _mm256_set1_epi32(sc->hi[2]);
    const __m256i cx = _mm256_set1_epi32(sc->cell[0]), cy = _mm256_set1_epi32(sc->cell[1]),
                  cz = _mm256_set1_epi32(sc->cell[2]);
    const __m128i sh = _mm_cvtsi32_si128((int)sc->s);
    const __m256i mev = _mm256_set1_epi32((int)me);
    lc_ties *const t = sc->ties;
    const unsigned common = (unsigned)t->common;
    size_t r, nt = t->n;
    for (r = first; r < end; r += 8) {
        const __m256i L0 = _mm256_loadu_si256((const __m256i *)(X0 + r)),
                      H0 = _mm256_loadu_si256((const __m256i *)(X1 + r));
        const __m256i L1 = _mm256_loadu_si256((const __m256i *)(Y0 + r)),
                      H1 = _mm256_loadu_si256((const __m256i *)(Y1 + r));
        const __m256i L2 = _mm256_loadu_si256((const __m256i *)(Z0 + r)),
                      H2 = _mm256_loadu_si256((const __m256i *)(Z1 + r));
        /* Independent compares, one OR tree: the reject test. */
        const __m256i rej = _mm256_or_si256(
            _mm256_or_si256(_mm256_or_si256(_mm256_cmpgt_epi32(lo0, H0), _mm256_cmpgt_epi32(L0, hi0)),
                            _mm256_or_si256(_mm256_cmpgt_epi32(lo1, H1), _mm256_cmpgt_epi32(L1, hi1))),
            _mm256_or_si256(_mm256_cmpgt_epi32(lo2, H2), _mm256_cmpgt_epi32(L2, hi2)));
        unsigned m = ~(unsigned)_mm256_movemask_ps(_mm256_castsi256_ps(rej)) & 0xffu, weak;
        if (end - r < 8) /* past `end` lie padding or stale rows: masked off */
            m &= (1u << (end - r)) - 1u;
        /* No early exit when no lane is left: the runs are short (about 7
           candidates on the clustered5 scene) and about half their blocks
           hold a pair, so that branch mispredicted on half the blocks. A
           block with none stores nothing the count keeps (m = 0), inside
           the pair buffer's slack. */
        {
            /* Canonical cell: the intersection's low corner lies in this cell. */
            const __m256i canon = _mm256_and_si256(
                _mm256_and_si256(_mm256_cmpeq_epi32(_mm256_sra_epi32(_mm256_max_epi32(L0, lo0), sh), cx),
                                 _mm256_cmpeq_epi32(_mm256_sra_epi32(_mm256_max_epi32(L1, lo1), sh), cy)),
                _mm256_cmpeq_epi32(_mm256_sra_epi32(_mm256_max_epi32(L2, lo2), sh), cz));
            /* Strictly inside each other's quantized range: a true overlap.
               Equal ends need the exact test. */
            const __m256i strict = _mm256_and_si256(
                _mm256_and_si256(_mm256_and_si256(_mm256_cmpgt_epi32(H0, lo0), _mm256_cmpgt_epi32(hi0, L0)),
                                 _mm256_and_si256(_mm256_cmpgt_epi32(H1, lo1), _mm256_cmpgt_epi32(hi1, L1))),
                _mm256_and_si256(_mm256_cmpgt_epi32(H2, lo2), _mm256_cmpgt_epi32(hi2, L2)));
            m &= (unsigned)_mm256_movemask_ps(_mm256_castsi256_ps(canon));
            weak = m & ~(unsigned)_mm256_movemask_ps(_mm256_castsi256_ps(strict));
        }
        if (!split) { /* every lane left is a pair: written in lane order, no loop */
            /* The ties' places to t, tested at the next flush. Where ties
               are common, with no branch on this block's; where they are
               rare, the branch is as good as never taken. */
            if (common | weak) {
                __m256i at;
                if (nt > LC_TIES - 8 || np - t->base > 0x7fffffffu) { /* full, or past 32-bit offsets */
                    t->n = nt;
                    np = ties_flush_avx2(t, sc->boxes, f64, pairs, np, exact);
                    nt = 0;
                }
                at =
                    _mm256_add_epi32(_mm256_set1_epi32((int)(np - t->base)),
                                     _mm256_cvtepu8_epi32(_mm_loadl_epi64((const __m128i *)(lc_rank8 + m))));
                _mm256_storeu_si256((__m256i *)(t->pos + nt),
                                    _mm256_permutevar8x32_epi32(
                                        at, _mm256_cvtepu8_epi32(_mm_loadl_epi64((const __m128i *)(lc_compress8 + weak)))));
                nt += (size_t)__builtin_popcount(weak);
            }
            np = store_pairs_avx2(pairs, np, _mm256_loadu_si256((const __m256i *)(J + r)), mev, m);
            continue;
        }
        if (weak)
            m = exact_lanes_avx2(sc, f64, J + r, m, weak, exact);
        for (; m; m &= m - 1) { /* in lane order, as the scalar path */
            const uint32_t j = J[r + (unsigned)__builtin_ctz(m)];
            if ((j < split) == (me < split))
                continue; /* two sets: both objects in the same one */
            pairs[2 * np] = j < me ? j : me;
            pairs[2 * np + 1] = j < me ? me : j;
            np++;
        }
    }
    t->n = nt;
    return np;
}

/* scan_avx2_of as an lc_scan_fn (the precision from sc). */
LC_AVX2 static size_t scan_avx2(const lc_scan *sc, size_t first, size_t end, uint32_t *pairs, size_t np,
                                uint64_t *exact)
{
    return scan_avx2_of(sc, first, end, pairs, np, exact, sc->f64);
}
#endif

#if defined(__GNUC__) && defined(__aarch64__) && defined(__ARM_NEON)
#define LC_HAVE_NEON_KERNEL 1
#include "sweep_neon.h"
#endif


static lc_filter_fn pick_filter(int kernel)
{
#ifdef LC_HAVE_NEON_KERNEL
    if (kernel == LC_KERNEL_NEON)
        return filter_neon;
#endif
#ifdef LC_HAVE_AVX2_KERNEL
    if (kernel >= LC_KERNEL_AVX2)
        return filter_avx2;
#endif
    (void)kernel;
    return filter_scalar;
}

static lc_scan_fn pick_scan(int kernel)
{
#ifdef LC_HAVE_NEON_KERNEL
    if (kernel == LC_KERNEL_NEON)
        return scan_neon;
#endif
#ifdef LC_HAVE_AVX2_KERNEL
    if (kernel >= LC_KERNEL_AVX2)
        return scan_avx2;
#endif
    (void)kernel;
    return scan_scalar;
}

/* What one sweep call reads, and what it counts. The functions of
 * sweep_impl.h that take it are inlined into the loop and nothing takes
 * its address, so the compiler keeps it in registers. */
typedef struct lc_sweep_ctx {
    const locd_grid *g;
    uint32_t ib, depth; /* g's index bits and depth */
    const uint64_t *qbox, *entries;
    lc_sweep_out *o;
    lc_scan_fn scan; /* the generic loops' scan (scalar or AVX2) */
    size_t npairs;   /* pairs in o->pairs */
    uint64_t candidates, exact;
} lc_sweep_ctx;

/* The sweep's working state, which the segment functions, the cell loader
 * and the scan take by address. */
typedef struct lc_sweep_state {
    lc_seg segs[LC_MAX_SEGS];
    uint32_t nseg;
    size_t ncand; /* records in use (the segments' and the open cell's) */
    lc_scan sc;   /* the entry being tested, and its cell */
    lc_slabs sl;  /* the bucket order of the last cell loaded with one */
    size_t slab[LC_BUCKETS + 1]; /* its buckets' first rows */
    int64_t ext[2];              /* its largest x and y extents */
    lc_anc an;                   /* the open dense cell's ancestors in x order, if on */
    lc_ties ties;                /* the AVX2 scan's ties not yet tested */
} lc_sweep_state;

static void sweep_ctx_init(lc_sweep_ctx *cx, lc_sweep_state *ss, const locd_grid *g, const void *boxes, int f64,
                           const uint64_t *qbox, const uint64_t *entries, lc_sweep_out *o)
{
    cx->g = g;
    cx->ib = g->index_bits;
    cx->depth = g->depth;
    cx->qbox = qbox;
    cx->entries = entries;
    cx->o = o;
    cx->scan = pick_scan(o->kernel);
    cx->npairs = o->count; /* the pairs of earlier ranges stay */
    cx->candidates = cx->exact = 0;
    ss->nseg = 0;
    ss->ncand = 0;
    ss->an.on = 0;
    ss->sc.boxes = boxes;
    ss->sc.f64 = f64;
    ss->sc.split = o->split;
    ss->ties.n = 0;
    ss->ties.base = cx->npairs;
    ss->ties.common = 0;
    ss->sc.ties = &ss->ties;
}

/* The end of the cell that starts at entry p: the next entry with another key. */
LC_INLINE size_t cell_end(const uint64_t *e, size_t p, size_t end, uint32_t ib)
{
    size_t q = p + 1;
    while (q < end && (e[q] >> ib) == (e[p] >> ib))
        q++;
    return q;
}

/* Pops the segments of cells that do not contain cell (pm, level): the
 * stack then holds its populated ancestors. */
LC_INLINE void pop_to_ancestors(lc_sweep_state *ss, uint64_t pm, uint32_t level, uint32_t depth)
{
    while (ss->nseg) {
        const lc_seg *sg = &ss->segs[ss->nseg - 1];
        if (sg->level < level && (pm >> (3u * (depth - sg->level))) == sg->cm)
            break;
        ss->ncand = sg->start;
        ss->nseg--;
    }
}

/* Counts `cand` candidates for the entry about to be tested and makes room
 * for as many pairs (plus the vector stores' slack). */
LC_INLINE locd_status reserve_pairs(lc_sweep_ctx *cx, size_t cand)
{
    const size_t need = cx->npairs + cand + LC_PAIR_SLACK;
    cx->candidates += cand;
    if (2 * need > cx->o->pairs.cap)
        return pairs_reserve(cx->o, 2 * need, cx->npairs);
    return LOCD_OK;
}

/* Makes room for the pairs of at most `bound` candidates without counting
 * them (the caller counts the ones it tests). */
LC_INLINE locd_status reserve_room(lc_sweep_ctx *cx, size_t bound)
{
    const size_t need = cx->npairs + bound + LC_PAIR_SLACK;
    if (2 * need > cx->o->pairs.cap)
        return pairs_reserve(cx->o, 2 * need, cx->npairs);
    return LOCD_OK;
}

/* Makes box q (lo xyz, hi xyz) of object idx the entry under test. */
LC_INLINE void entry_from_box(lc_scan *sc, const int32_t q[6], uint32_t idx)
{
    sc->lo[0] = q[0];
    sc->lo[1] = q[1];
    sc->lo[2] = q[2];
    sc->hi[0] = q[3];
    sc->hi[1] = q[4];
    sc->hi[2] = q[5];
    sc->idx = idx;
}

/* Makes record r the entry under test. */
LC_INLINE void entry_from_row(lc_scan *sc, size_t r)
{
    sc->lo[0] = sc->c.lo[0][r];
    sc->lo[1] = sc->c.lo[1][r];
    sc->lo[2] = sc->c.lo[2][r];
    sc->hi[0] = sc->c.hi[0][r];
    sc->hi[1] = sc->c.hi[1][r];
    sc->hi[2] = sc->c.hi[2][r];
    sc->idx = sc->c.idx[r];
}

/* The main loop, once per input precision and per kernel family (the
 * include-template of octree.h): through the scan function pointer (the
 * portable loop: scalar), and with the AVX2 scan inlined into a
 * loop compiled for that target. */
#define LC_TARGET
#define LC_SCAN(cx, sc, first, end, pairs, np, exact) (cx)->scan(sc, first, end, pairs, np, exact)
#define LC_TIES_FLUSH(t, boxes, f64, pairs, np, exact) (np) /* no tie waits: see ties_flush_avx2 */
#define LC_T float
#define LC_SUFFIX f32_generic
#include "sweep_impl.h"
#define LC_T double
#define LC_SUFFIX f64_generic
#include "sweep_impl.h"
#undef LC_TARGET
#undef LC_SCAN
#undef LC_TIES_FLUSH

#ifdef LC_HAVE_AVX2_KERNEL
#define LC_TARGET LC_AVX2
#define LC_SCAN(cx, sc, first, end, pairs, np, exact) \
    scan_avx2_of(sc, first, end, pairs, np, exact, sizeof(LC_T) == sizeof(double))
#define LC_TIES_FLUSH ties_flush_avx2
#define LC_T float
#define LC_SUFFIX f32_avx2
#include "sweep_impl.h"
#define LC_T double
#define LC_SUFFIX f64_avx2
#include "sweep_impl.h"
#undef LC_TARGET
#undef LC_SCAN
#undef LC_TIES_FLUSH
#endif

#ifdef LC_HAVE_AVX512_KERNEL
/* lc_quantize on a box's six coordinates at once, to the sweep's 21 bits:
 * the same IEEE operations in the same order, so the same integers as
 * encode computed. */
LC_AVX512 LC_INLINE void quantize6(const locd_grid *g, __m512d x, int32_t q[8])
{
    const __m512d origin = _mm512_permutexvar_pd(_mm512_setr_epi64(0, 1, 2, 0, 1, 2, 0, 0),
                                                 _mm512_castpd256_pd512(_mm256_maskz_loadu_pd(0x7, g->origin)));
    const __m512d t = _mm512_mul_pd(
        _mm512_mul_pd(_mm512_sub_pd(_mm512_mul_pd(x, _mm512_set1_pd(0.5)), origin), _mm512_set1_pd(g->scale_a)),
        _mm512_set1_pd(g->scale_b));
    const __m512d c = _mm512_min_pd(_mm512_max_pd(t, _mm512_setzero_pd()), _mm512_set1_pd(LC_QMAX));
    _mm256_storeu_si256((__m256i *)q, _mm256_srai_epi32(_mm512_cvttpd_epi32(c), LC_SDROP));
}
/* The AVX-512 loop scans with the AVX2 scan, 8 candidates a block: an
 * entry's runs of candidates are short (about 7 on the clustered5 scene),
 * and a 16-lane scan spent its time on half-empty blocks and on the branch
 * that skips a block with no lane left. Measured on an AMD EPYC (Zen 5):
 * 10% to 20% faster than the 16-lane scan, which was removed
 * (bench/results/kernels_notes.md); not measured on an Intel CPU. */
#define LC_TARGET LC_AVX512
#define LC_SCAN(cx, sc, first, end, pairs, np, exact) \
    scan_avx2_of(sc, first, end, pairs, np, exact, sizeof(LC_T) == sizeof(double))
#define LC_TIES_FLUSH ties_flush_avx2
#define LC_T float
#define LC_SUFFIX f32_avx512
#define LC_QUANTIZE6(g, b, q) quantize6(g, _mm512_cvtps_pd(_mm256_maskz_loadu_ps(0x3f, b)), q)
#include "sweep_impl.h"
#undef LC_QUANTIZE6

#define LC_T double
#define LC_SUFFIX f64_avx512
#define LC_QUANTIZE6(g, b, q) quantize6(g, _mm512_maskz_loadu_pd(0x3f, b), q)
#include "sweep_impl.h"
#undef LC_QUANTIZE6
#undef LC_TARGET
#undef LC_SCAN
#undef LC_TIES_FLUSH
#endif

/* The kernel o was made for picks the loop. */
locd_status lc_sweep_range_f32(const locd_grid *g, const float *boxes, const uint64_t *qbox, const uint64_t *entries,
                               size_t count, size_t begin, size_t end, lc_sweep_out *o)
{
#ifdef LC_HAVE_AVX512_KERNEL
    if (o->kernel == LC_KERNEL_AVX512)
        return sweep_range_f32_avx512(g, boxes, qbox, entries, count, begin, end, o);
#endif
#ifdef LC_HAVE_AVX2_KERNEL
    if (o->kernel >= LC_KERNEL_AVX2)
        return sweep_range_f32_avx2(g, boxes, qbox, entries, count, begin, end, o);
#endif
    return sweep_range_f32_generic(g, boxes, qbox, entries, count, begin, end, o);
}

locd_status lc_sweep_range_f64(const locd_grid *g, const double *boxes, const uint64_t *qbox, const uint64_t *entries,
                               size_t count, size_t begin, size_t end, lc_sweep_out *o)
{
#ifdef LC_HAVE_AVX512_KERNEL
    if (o->kernel == LC_KERNEL_AVX512)
        return sweep_range_f64_avx512(g, boxes, qbox, entries, count, begin, end, o);
#endif
#ifdef LC_HAVE_AVX2_KERNEL
    if (o->kernel >= LC_KERNEL_AVX2)
        return sweep_range_f64_avx2(g, boxes, qbox, entries, count, begin, end, o);
#endif
    return sweep_range_f64_generic(g, boxes, qbox, entries, count, begin, end, o);
}

void lc_sweep_out_init(lc_sweep_out *o, const locd_allocator *a, int kernel)
{
    memset(o, 0, sizeof *o);
    o->alloc = a;
    o->kernel = kernel;
    o->filter = (void (*)(void))pick_filter(kernel);
}

void lc_sweep_out_fini(lc_sweep_out *o)
{
    lc_sweep_out_lend(o, NULL, 0);
    lc_buf_release(o->alloc, &o->pairs, sizeof(uint32_t));
    lc_buf_release(o->alloc, &o->group, sizeof(uint64_t));
    if (o->cand)
        lc_free(o->alloc, o->cand, LC_STRIDE(o->cand_cap) * 7 * sizeof(int32_t));
    o->cand = NULL;
    o->cand_cap = 0;
}
