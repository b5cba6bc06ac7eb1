/* The service, its jobs: admission against the limits, one FIFO run queue
 * fed by the connections, a fixed set of runner threads each with its own
 * level-1 engine, the RESULT of each job written back on its connection,
 * and stopping jobs: a queued job that was cancelled is answered unrun; a
 * running one is stopped by the engine's stop hook (engine.h, lc_stop),
 * which level 1 asks between its stages and between blocks of its sweep,
 * and by the runner's allocator, which refuses memory past the limits. */
#include "service/service.h"

#include <stdio.h>
#include <stdlib.h>

/* Why a running job was stopped (the first reason wins). */
enum { STOP_NONE, STOP_CANCELLED, STOP_JOB_MEMORY, STOP_CLIENT_MEMORY, STOP_JOB_PAIRS, STOP_CLIENT_PAIRS, STOP_TIME };

typedef struct runner {
    lc_server *s;
    locd_engine *engine;
    lc_submit_fixed cfg; /* the config the engine was made with */
    locd_pairs *pairs;
    locd_allocator alloc; /* counts what the engine and pairs hold (user: this runner) */
    pthread_mutex_t amu;  /* the fields below: the engine's threads allocate too */
    uint64_t used;        /* bytes the engine and pairs hold */
    uint64_t charged;     /* of which counted into job->c->bytes_in_flight */
    lc_srv_job *job;      /* the running job, NULL between jobs */
    double t_end;         /* its deadline (lc_now_ms) */
    int stop;             /* STOP_*: why it was stopped */
} runner;

/* ---- admission and retirement ---- */

static int cancelled(const lc_srv_job *j)
{
    return __atomic_load_n(&j->cancelled, __ATOMIC_ACQUIRE);
}

locd_status lc_srv_admit(lc_srv_conn *c, lc_srv_job *j, char *why, size_t wl)
{
    lc_server *s = c->s;
    const locd_service_config *cfg = &s->cfg;
    locd_status st = LOCD_ERR_LIMIT;
    pthread_mutex_lock(&s->mu);
    if (c->njobs >= cfg->max_jobs)
        snprintf(why, wl, "more than %u jobs in flight on one connection (the service's limit)", cfg->max_jobs);
    else if (j->f.n > cfg->max_job_boxes)
        snprintf(why, wl, "the job has %llu boxes, more than the service's limit of %llu per job",
                 (unsigned long long)j->f.n, (unsigned long long)cfg->max_job_boxes);
    else if ((uint64_t)j->bytes > cfg->max_job_memory)
        snprintf(why, wl, "the job's %zu bytes of boxes exceed the service's memory limit of %llu bytes per job",
                 j->bytes, (unsigned long long)cfg->max_job_memory);
    else if (c->boxes_in_flight + j->f.n > cfg->max_client_boxes)
        snprintf(why, wl, "this client's jobs in flight would hold more than %llu boxes (the service's limit)",
                 (unsigned long long)cfg->max_client_boxes);
    else if (__atomic_load_n(&c->bytes_in_flight, __ATOMIC_RELAXED) + j->bytes > cfg->max_client_memory)
        snprintf(why, wl, "this client's jobs in flight would hold more than %llu bytes (the service's limit)",
                 (unsigned long long)cfg->max_client_memory);
    else
        st = LOCD_OK;
    if (st == LOCD_OK) {
        j->c = c;
        c->refs++;
        c->njobs++;
        c->boxes_in_flight += j->f.n;
        __atomic_add_fetch(&c->bytes_in_flight, (uint64_t)j->bytes, __ATOMIC_RELAXED);
        j->cnext = c->jobs;
        if (c->jobs)
            c->jobs->cprev = j;
        c->jobs = j;
    }
    pthread_mutex_unlock(&s->mu);
    return st;
}

void lc_srv_job_free(lc_srv_job *j)
{
    free(j->boxes);
    free(j);
}

void lc_srv_job_retire(lc_srv_job *j)
{
    lc_srv_conn *c = j->c;
    lc_server *s = c->s;
    pthread_mutex_lock(&s->mu);
    if (j->cprev)
        j->cprev->cnext = j->cnext;
    else
        c->jobs = j->cnext;
    if (j->cnext)
        j->cnext->cprev = j->cprev;
    if (!j->answered)
        c->njobs--;
    c->boxes_in_flight -= j->f.n;
    __atomic_sub_fetch(&c->bytes_in_flight, (uint64_t)j->bytes, __ATOMIC_RELAXED);
    lc_srv_conn_unref_locked(c);
    pthread_mutex_unlock(&s->mu);
    lc_srv_job_free(j);
}

void lc_srv_enqueue(lc_srv_conn *c, lc_srv_job *j)
{
    lc_server *s = c->s;
    pthread_mutex_lock(&s->mu);
    if (s->qtail)
        s->qtail->qnext = j;
    else
        s->qhead = j;
    s->qtail = j;
    pthread_cond_signal(&s->cv);
    pthread_mutex_unlock(&s->mu);
}

void lc_srv_cancel(lc_srv_conn *c, uint64_t id)
{
    lc_srv_job *j;
    pthread_mutex_lock(&c->s->mu);
    for (j = c->jobs; j; j = j->cnext)
        if (j->id == id)
            __atomic_store_n(&j->cancelled, 1, __ATOMIC_RELEASE);
    pthread_mutex_unlock(&c->s->mu);
}

void lc_srv_cancel_all_locked(lc_srv_conn *c)
{
    lc_srv_job *j;
    for (j = c->jobs; j; j = j->cnext)
        __atomic_store_n(&j->cancelled, 1, __ATOMIC_RELEASE);
}

/* ---- the runner's allocator and stop hook ---- */

/* Records the first reason to stop; returns 0 (for the allocator's NULL). */
static int stop_for(runner *r, int why)
{
    if (!r->stop)
        r->stop = why;
    return 0;
}

/* Under r->amu: 1 when the running job may take size more bytes. */
static int may_allocate(runner *r, size_t size)
{
    const locd_service_config *cfg = &r->s->cfg;
    lc_srv_job *j = r->job;
    if (!j)
        return 1;
    if (r->stop)
        return 0;
    if (cancelled(j))
        return stop_for(r, STOP_CANCELLED);
    if ((uint64_t)j->bytes + r->used + size > cfg->max_job_memory)
        return stop_for(r, STOP_JOB_MEMORY);
    if (__atomic_add_fetch(&j->c->bytes_in_flight, (uint64_t)size, __ATOMIC_RELAXED) > cfg->max_client_memory) {
        __atomic_sub_fetch(&j->c->bytes_in_flight, (uint64_t)size, __ATOMIC_RELAXED);
        return stop_for(r, STOP_CLIENT_MEMORY);
    }
    r->charged += size;
    return 1;
}

static void *runner_alloc(size_t size, void *user)
{
    runner *r = user;
    void *p = NULL;
    pthread_mutex_lock(&r->amu);
    if (may_allocate(r, size)) {
        p = malloc(size);
        if (p)
            r->used += size;
        else if (r->job) { /* give the charge back */
            r->charged -= size;
            __atomic_sub_fetch(&r->job->c->bytes_in_flight, (uint64_t)size, __ATOMIC_RELAXED);
        }
    }
    pthread_mutex_unlock(&r->amu);
    return p;
}

static void runner_free(void *p, size_t size, void *user)
{
    runner *r = user;
    if (!p)
        return;
    free(p);
    pthread_mutex_lock(&r->amu);
    r->used -= size;
    if (r->job && r->charged >= size) {
        r->charged -= size;
        __atomic_sub_fetch(&r->job->c->bytes_in_flight, (uint64_t)size, __ATOMIC_RELAXED);
    }
    pthread_mutex_unlock(&r->amu);
}

/* lc_stop.check: asked by the running find with the pairs it has so far. */
static int runner_check(void *user, uint64_t pairs)
{
    runner *r = user;
    const locd_service_config *cfg = &r->s->cfg;
    lc_srv_job *j;
    int stop;
    pthread_mutex_lock(&r->amu);
    j = r->job;
    if (j && !r->stop) {
        if (cancelled(j) || __atomic_load_n(&r->s->stopping, __ATOMIC_RELAXED))
            stop_for(r, STOP_CANCELLED);
        else if (pairs > cfg->max_job_pairs)
            stop_for(r, STOP_JOB_PAIRS);
        else if (lc_now_ms() > r->t_end)
            stop_for(r, STOP_TIME);
        if (!r->stop && pairs > j->pairs_seen) {
            uint64_t all = __atomic_add_fetch(&j->c->pairs_running, pairs - j->pairs_seen, __ATOMIC_RELAXED);
            j->pairs_seen = pairs;
            if (all > cfg->max_client_pairs)
                stop_for(r, STOP_CLIENT_PAIRS);
        }
    }
    stop = r->stop;
    pthread_mutex_unlock(&r->amu);
    if (!stop)
        return 0;
    return stop == STOP_CANCELLED ? LOCD_ERR_CANCELLED : LOCD_ERR_LIMIT;
}

/* Starts (j) or ends (NULL) the runner's accounting for a job. */
static void runner_track(runner *r, lc_srv_job *j)
{
    pthread_mutex_lock(&r->amu);
    if (r->job) {
        __atomic_sub_fetch(&r->job->c->bytes_in_flight, r->charged, __ATOMIC_RELAXED);
        __atomic_sub_fetch(&r->job->c->pairs_running, r->job->pairs_seen, __ATOMIC_RELAXED);
    }
    r->charged = 0;
    r->stop = STOP_NONE;
    r->job = j;
    if (j) {
        /* What the engine kept from earlier jobs is this job's too. */
        r->charged = r->used;
        __atomic_add_fetch(&j->c->bytes_in_flight, r->used, __ATOMIC_RELAXED);
        r->t_end = lc_now_ms() + (double)r->s->cfg.max_job_ms;
    }
    if (r->engine) /* the sweep polls the job's own cancel flag */
        r->engine->stop.flag = j ? &j->cancelled : NULL;
    pthread_mutex_unlock(&r->amu);
}

/* The status and message of a job the runner stopped. */
static locd_status stop_status(const runner *r, char *msg, size_t ml)
{
    const locd_service_config *cfg = &r->s->cfg;
    switch (r->stop) {
    case STOP_JOB_MEMORY:
        snprintf(msg, ml, "the job needs more memory than the service's limit of %llu MiB per job",
                 (unsigned long long)(cfg->max_job_memory >> 20));
        break;
    case STOP_CLIENT_MEMORY:
        snprintf(msg, ml, "this client's jobs need more memory than the service's limit of %llu MiB per client",
                 (unsigned long long)(cfg->max_client_memory >> 20));
        break;
    case STOP_JOB_PAIRS:
        snprintf(msg, ml, "the job has more than %llu pairs, the service's limit per job",
                 (unsigned long long)cfg->max_job_pairs);
        break;
    case STOP_CLIENT_PAIRS:
        snprintf(msg, ml, "this client's running jobs have more than %llu pairs, the service's limit per client",
                 (unsigned long long)cfg->max_client_pairs);
        break;
    case STOP_TIME:
        snprintf(msg, ml, "the job ran longer than the service's limit of %u ms per job", cfg->max_job_ms);
        break;
    default:
        snprintf(msg, ml, "cancelled");
        return LOCD_ERR_CANCELLED;
    }
    return LOCD_ERR_LIMIT;
}

/* ---- running a job ---- */

/* Keeps the runner's engine when the job's config matches the last one. */
static locd_status runner_engine(runner *r, const lc_submit_fixed *f)
{
    locd_engine_config cfg;
    locd_status st;
    if (r->engine && r->cfg.max_depth == f->max_depth && r->cfg.cell_bias == f->cell_bias &&
        r->cfg.config_flags == f->config_flags)
        return LOCD_OK;
    locd_engine_destroy(r->engine);
    r->engine = NULL;
    locd_engine_config_init(&cfg);
    cfg.level = LOCD_LEVEL_INPROCESS;
    cfg.threads = r->s->cfg.engine_threads ? r->s->cfg.engine_threads : 1;
    cfg.max_depth = f->max_depth;
    cfg.cell_bias = f->cell_bias;
    cfg.flags = f->config_flags;
    cfg.allocator = r->alloc;
    r->cfg = *f;
    if ((st = locd_engine_create(&cfg, &r->engine)) != LOCD_OK)
        return st;
    r->engine->stop.check = runner_check;
    r->engine->stop.user = r;
    r->engine->stop.flag = &r->job->cancelled;
    return LOCD_OK;
}

/* Sends the job's RESULT. The job stops counting as in flight first: the
 * client may submit its next one as soon as it has read this, before the
 * runner retires this job, and it throttles on the RESULTs it has seen. */
static void answer(lc_srv_job *j, locd_status st, const char *msg, int64_t index, const locd_stats *stats,
                   const uint32_t *pairs, size_t count)
{
    lc_server *s = j->c->s;
    pthread_mutex_lock(&s->mu);
    j->c->njobs--;
    j->answered = 1;
    pthread_mutex_unlock(&s->mu);
    lc_srv_send_result(j->c, j->id, st, msg, index, stats, pairs, count);
}

static int job_cancelled(lc_srv_job *j)
{
    if (!cancelled(j))
        return 0;
    answer(j, LOCD_ERR_CANCELLED, "cancelled", -1, NULL, NULL, 0);
    return 1;
}

static void run_job(runner *r, lc_srv_job *j)
{
    locd_stats st;
    locd_status rc;
    if (job_cancelled(j))
        return;
    rc = runner_engine(r, &j->f);
    if (!rc && !r->pairs)
        rc = locd_pairs_create(&r->alloc, &r->pairs);
    if (!rc)
        rc = j->f.f64 ? locd_engine_find_pairs_f64(r->engine, j->boxes, (size_t)j->f.n, j->f.flags, r->pairs)
                      : locd_engine_find_pairs_f32(r->engine, j->boxes, (size_t)j->f.n, j->f.flags, r->pairs);
    if (rc && cancelled(j))
        stop_for(r, STOP_CANCELLED);
    if (rc && r->stop) {
        char msg[200];
        rc = stop_status(r, msg, sizeof msg);
        answer(j, rc, msg, -1, NULL, NULL, 0);
        return;
    }
    if (rc) {
        answer(j, rc, lc_last_error_detail(), locd_last_error_index(), NULL, NULL, 0);
        return;
    }
    if (job_cancelled(j)) /* cancelled while running: dropped */
        return;
    locd_stats_init(&st);
    locd_engine_get_stats(r->engine, &st);
    answer(j, LOCD_OK, NULL, -1, &st, locd_pairs_data(r->pairs), locd_pairs_count(r->pairs));
}

/* A huge job's buffers (engine and result) go once it is answered: the
 * next job grows its own. */
static void runner_shrink(runner *r)
{
    uint64_t used;
    pthread_mutex_lock(&r->amu);
    used = r->used;
    pthread_mutex_unlock(&r->amu);
    if (used <= LC_SRV_KEEP_BYTES)
        return;
    locd_pairs_destroy(r->pairs);
    r->pairs = NULL;
    locd_engine_destroy(r->engine);
    r->engine = NULL;
}

/* The next queued job; NULL when the service stops (or, with drain, when
 * the queue is empty). */
static lc_srv_job *next_job(lc_server *s, int drain)
{
    lc_srv_job *j;
    pthread_mutex_lock(&s->mu);
    while (!s->qhead && !s->stopping && !drain)
        pthread_cond_wait(&s->cv, &s->mu);
    j = s->qhead;
    if (j) {
        s->qhead = j->qnext;
        if (!s->qhead)
            s->qtail = NULL;
    }
    pthread_mutex_unlock(&s->mu);
    return j;
}

/* One runner: runs queued jobs until the service stops (drain: until the
 * queue is empty). */
static void run_queue(lc_server *s, int drain)
{
    runner r;
    lc_srv_job *j;
    memset(&r, 0, sizeof r);
    r.s = s;
    r.alloc.alloc = runner_alloc;
    r.alloc.free = runner_free;
    r.alloc.user = &r;
    pthread_mutex_init(&r.amu, NULL);
    while ((j = next_job(s, drain)) != NULL) {
        runner_track(&r, j);
        run_job(&r, j);
        runner_track(&r, NULL);
        runner_shrink(&r);
        lc_srv_job_retire(j);
        pthread_mutex_lock(&s->mu);
        s->served++;
        pthread_mutex_unlock(&s->mu);
    }
    locd_engine_destroy(r.engine);
    locd_pairs_destroy(r.pairs);
    pthread_mutex_destroy(&r.amu);
}

void *lc_srv_runner_main(void *service)
{
    run_queue(service, 0);
    return NULL;
}

void lc_srv_run_queued(lc_server *s)
{
    run_queue(s, 1);
}
