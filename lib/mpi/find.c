/* locd_mpi_find_pairs_*: the stages of one call (docs/cluster.md), each
 * ending where every rank agrees on its status, so that an error on one
 * rank becomes the same error on all and no rank waits on one that left. */
#include "mpi/part.h"

#include <stdlib.h>

/* Splitter samples per rank past which the sample gather's int counts
 * could overflow on large communicators. */
#define LM_MAX_SAMPLES (1u << 16)

void locd_mpi_options_init(locd_mpi_options *options)
{
    if (!options)
        return;
    memset(options, 0, sizeof *options);
    options->size = sizeof *options;
    options->strategy = LOCD_MPI_DISTRIBUTED;
    options->threads = 1;
    options->gather_root = -1;
    options->cell_bias = LOCD_DEFAULT_CELL_BIAS;
}

void locd_mpi_stats_init(locd_mpi_stats *stats)
{
    if (!stats)
        return;
    memset(stats, 0, sizeof *stats);
    stats->size = sizeof *stats;
}

/* This rank's own arguments (the agreement comes in lm_setup). */
static locd_status check_local(lm_ctx *c, const locd_mpi_options *opt, const locd_pairs *out,
                               const locd_mpi_stats *stats)
{
    locd_status st;
    if (opt && (st = lc_struct_in(&c->opt, sizeof c->opt, opt, LOCD_MPI_OPTIONS_MIN_SIZE, "options")) != LOCD_OK)
        return st;
    if (stats && (st = lc_struct_check(stats, sizeof *stats, LOCD_MPI_STATS_MIN_SIZE, "stats")) != LOCD_OK)
        return st;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    if (out->magic != LC_MAGIC_PAIRS)
        return lc_error(LOCD_ERR_INVALID_HANDLE, "out is not a locd_pairs");
    if (!c->boxes && c->local_n)
        return lc_error(LOCD_ERR_NULL_POINTER, "boxes is NULL");
    if (c->opt.strategy != LOCD_MPI_DISTRIBUTED && c->opt.strategy != LOCD_MPI_MASTER)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "strategy %d is not LOCD_MPI_DISTRIBUTED or LOCD_MPI_MASTER",
                        (int)c->opt.strategy);
    if (c->opt.gather_root < -1)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "gather_root %d is neither -1 nor a rank", (int)c->opt.gather_root);
    if (c->opt.threads > LC_MAX_THREADS)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "threads %u exceeds %d", c->opt.threads, LC_MAX_THREADS);
    if (c->opt.samples > LM_MAX_SAMPLES)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "samples %u exceeds %u", c->opt.samples, LM_MAX_SAMPLES);
    if ((uint64_t)c->local_n > (uint64_t)UINT32_MAX + 1u)
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "%zu objects do not fit a 32-bit index", c->local_n);
    return LOCD_OK;
}

/* Every rank's pairs to gather_root, in rank order: the whole sweep's order. */
static locd_status gather_pairs(lm_ctx *c, int root, locd_pairs **mine)
{
    uint64_t *counts = malloc((size_t)c->ranks * sizeof *counts), total = 0;
    locd_pairs *all = NULL;
    MPI_Datatype pair_type;
    locd_status st = counts ? LOCD_OK : lc_error(LOCD_ERR_NO_MEMORY, "pair counts");
    int r;
    if ((st = lm_agree(c, st)) != LOCD_OK) {
        free(counts);
        return st;
    }
    lm_allgather_u64(c, locd_pairs_count(*mine), counts);
    for (r = 0; r < c->ranks; r++)
        total += counts[r];
    if (c->rank == root) {
        st = locd_pairs_create(&(*mine)->alloc, &all);
        if (!st)
            st = lc_pairs_reserve(all, (size_t)total);
    }
    if ((st = lm_agree(c, st)) == LOCD_OK) {
        MPI_Type_contiguous(2, MPI_UINT32_T, &pair_type);
        MPI_Type_commit(&pair_type);
        lm_gather(c, root, (*mine)->data, counts, all ? all->data : NULL, pair_type, 2 * sizeof(uint32_t));
        MPI_Type_free(&pair_type);
        if (all) {
            all->count = (size_t)total;
            locd_pairs_destroy(*mine);
            *mine = all;
            all = NULL;
        } else {
            (*mine)->count = 0;
        }
    }
    locd_pairs_destroy(all);
    free(counts);
    return st;
}

/* Imbalance: the largest rank's sweep work over the mean. */
static void imbalance(lm_ctx *c)
{
    double *w = malloc((size_t)c->ranks * sizeof *w), mine = (double)(c->st.entries_held + c->st.candidates);
    double max = 0.0, sum = 0.0;
    int r, ok = w != NULL, all_ok;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, c->comm);
    if (all_ok) {
        MPI_Allgather(&mine, 1, MPI_DOUBLE, w, 1, MPI_DOUBLE, c->comm);
        for (r = 0; r < c->ranks; r++) {
            sum += w[r];
            max = w[r] > max ? w[r] : max;
        }
        c->st.imbalance = sum > 0.0 ? max * c->ranks / sum : 1.0;
    }
    free(w);
}

static locd_status stages(lm_ctx *c, locd_pairs *mine)
{
    lm_held h;
    uint64_t *split = NULL;
    locd_status st;
    memset(&h, 0, sizeof h);
    st = lm_fit_grid(c); /* a bad box, or a grid error, is the same on every rank */
    c->st.ms_bounds = lm_lap(c);
    if (!st)
        st = lm_agree(c, lm_encode(c));
    c->st.ms_encode = lm_lap(c);
    if (!st && c->opt.strategy == LOCD_MPI_DISTRIBUTED) {
        split = malloc(((size_t)c->ranks + 1) * sizeof *split);
        st = lm_agree(c, split ? LOCD_OK : lc_error(LOCD_ERR_NO_MEMORY, "splitters"));
        if (!st)
            st = lm_splitters(c, split);
        c->st.ms_split = lm_lap(c);
        if (!st)
            st = lm_exchange(c, split, &h);
    } else if (!st) {
        st = lm_master_gather(c, c->opt.gather_root >= 0 ? c->opt.gather_root : 0, &h);
    }
    if (!st) {
        st = lm_agree(c, lm_sweep(c, &h, mine));
        c->st.ms_sweep = lm_lap(c);
    }
    lm_held_free(&h);
    free(split);
    free(c->ent);
    c->ent = NULL;
    return st;
}

static locd_status find(MPI_Comm comm, const void *boxes, size_t local_n, int f64, const locd_mpi_options *opt,
                        locd_pairs *out, locd_mpi_stats *stats)
{
    lm_ctx c;
    locd_pairs *mine = NULL;
    locd_status st;
    int flag = 0;
    const double t0 = lc_now_ms();
    if (comm == MPI_COMM_NULL)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "comm is MPI_COMM_NULL");
    MPI_Initialized(&flag);
    if (!flag)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "MPI is not initialized");
    memset(&c, 0, sizeof c);
    c.comm = comm;
    MPI_Comm_rank(comm, &c.rank);
    MPI_Comm_size(comm, &c.ranks);
    c.f64 = f64;
    c.es = 6 * (f64 ? sizeof(double) : sizeof(float));
    c.boxes = boxes;
    c.local_n = local_n;
    c.kernel = lc_kernel_choose();
    c.lap = t0;
    locd_mpi_options_init(&c.opt);
    locd_mpi_stats_init(&c.st);
    st = check_local(&c, opt, out, stats);
    if (!st) /* the pairs this rank finds: *out changes only once every rank succeeded */
        st = locd_pairs_create(&out->alloc, &mine);
    st = lm_setup(&c, st);
    if (!st)
        st = stages(&c, mine);
    if (!st && c.opt.strategy == LOCD_MPI_DISTRIBUTED && c.opt.gather_root >= 0)
        st = gather_pairs(&c, c.opt.gather_root, &mine);
    if (!st && (c.opt.find_flags & LOCD_FIND_SORTED))
        st = lm_agree(&c, locd_pairs_sort(mine));
    if (!st)
        st = lm_agree(&c, lc_pairs_reserve(out, locd_pairs_count(mine)));
    if (!st) {
        if (mine->count)
            memcpy(out->data, mine->data, mine->count * 2 * sizeof(uint32_t));
        out->count = mine->count;
        c.st.ms_gather = lm_lap(&c);
        imbalance(&c);
        c.st.rank = c.rank;
        c.st.ranks = c.ranks;
        c.st.strategy = c.opt.strategy;
        c.st.objects = c.n;
        c.st.local_objects = local_n;
        c.st.first_index = c.offsets[c.rank];
        c.st.pairs = out->count;
        c.st.ms_total = lc_now_ms() - t0;
        if (stats)
            lc_struct_out(stats, &c.st);
        lc_clear_error();
    }
    locd_pairs_destroy(mine);
    free(c.offsets);
    return st;
}

locd_status locd_mpi_find_pairs_f32(MPI_Comm comm, const float *boxes, size_t local_n, const locd_mpi_options *options,
                                    locd_pairs *out, locd_mpi_stats *stats)
{
    return find(comm, boxes, local_n, 0, options, out, stats);
}

locd_status locd_mpi_find_pairs_f64(MPI_Comm comm, const double *boxes, size_t local_n,
                                    const locd_mpi_options *options, locd_pairs *out, locd_mpi_stats *stats)
{
    return find(comm, boxes, local_n, 1, options, out, stats);
}
