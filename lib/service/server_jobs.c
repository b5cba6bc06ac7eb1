/* The service, its jobs: one FIFO run queue fed by the connections, a
 * fixed set of runner threads each with its own level-1 engine, the
 * RESULT of each job written back on its connection, and cancelling (a
 * queued job is answered unrun, a running one is discarded when it ends). */
#include "service/service.h"

#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>

typedef struct runner {
    lc_server *s;
    locd_engine *engine;
    lc_submit_fixed cfg; /* the config the engine was made with */
    locd_pairs *pairs;
} runner;

void lc_srv_job_free(lc_srv_job *j)
{
    if (j->boxes) {
        if (j->mapped)
            munmap(j->boxes, j->bytes);
        else
            free(j->boxes);
    }
    free(j);
}

/* Detaches a finished job from its connection and frees it. */
static void job_retire(lc_server *s, lc_srv_job *j)
{
    lc_srv_conn *c = j->c;
    pthread_mutex_lock(&s->mu);
    if (j->cprev)
        j->cprev->cnext = j->cnext;
    else
        c->jobs = j->cnext;
    if (j->cnext)
        j->cnext->cprev = j->cprev;
    c->njobs--;
    lc_srv_conn_unref_locked(c);
    pthread_mutex_unlock(&s->mu);
    lc_srv_job_free(j);
}

int lc_srv_enqueue(lc_srv_conn *c, lc_srv_job *j, char *why, size_t wl)
{
    lc_server *s = c->s;
    pthread_mutex_lock(&s->mu);
    if (c->njobs >= s->cfg.max_jobs) {
        pthread_mutex_unlock(&s->mu);
        snprintf(why, wl, "more than %u jobs in flight", s->cfg.max_jobs);
        return 0;
    }
    j->c = c;
    c->refs++;
    c->njobs++;
    j->cnext = c->jobs;
    if (c->jobs)
        c->jobs->cprev = j;
    c->jobs = j;
    if (s->qtail)
        s->qtail->qnext = j;
    else
        s->qhead = j;
    s->qtail = j;
    pthread_cond_signal(&s->cv);
    pthread_mutex_unlock(&s->mu);
    return 1;
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

/* Keeps the runner's engine when the job's config matches the last one. */
static locd_status runner_engine(runner *r, const lc_submit_fixed *f)
{
    locd_engine_config cfg;
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
    r->cfg = *f;
    return locd_engine_create(&cfg, &r->engine);
}

static int job_cancelled(lc_srv_job *j)
{
    if (!__atomic_load_n(&j->cancelled, __ATOMIC_ACQUIRE))
        return 0;
    lc_srv_send_result(j->c, j->id, LOCD_ERR_CANCELLED, "cancelled", -1, NULL, NULL, 0);
    return 1;
}

static void run_job(runner *r, lc_srv_job *j)
{
    locd_stats st;
    locd_status rc;
    if (job_cancelled(j))
        return;
    rc = runner_engine(r, &j->f);
    if (!rc)
        rc = j->f.f64 ? locd_engine_find_pairs_f64(r->engine, j->boxes, (size_t)j->f.n, j->f.flags, r->pairs)
                      : locd_engine_find_pairs_f32(r->engine, j->boxes, (size_t)j->f.n, j->f.flags, r->pairs);
    if (rc) {
        lc_srv_send_result(j->c, j->id, rc, lc_last_error_detail(), locd_last_error_index(), NULL, NULL, 0);
        return;
    }
    if (job_cancelled(j)) /* cancelled while running: dropped */
        return;
    locd_stats_init(&st);
    locd_engine_stats(r->engine, &st);
    lc_srv_send_result(j->c, j->id, LOCD_OK, NULL, -1, &st, locd_pairs_data(r->pairs), locd_pairs_count(r->pairs));
}

/* The next queued job; NULL when the service stops. */
static lc_srv_job *next_job(lc_server *s)
{
    lc_srv_job *j;
    pthread_mutex_lock(&s->mu);
    while (!s->qhead && !s->stopping)
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

void *lc_srv_runner_main(void *service)
{
    runner r;
    lc_server *s = service;
    lc_srv_job *j;
    memset(&r, 0, sizeof r);
    r.s = s;
    if (locd_pairs_create(NULL, &r.pairs) != LOCD_OK)
        return NULL;
    while ((j = next_job(s)) != NULL) {
        run_job(&r, j);
        job_retire(s, j);
        pthread_mutex_lock(&s->mu);
        s->served++;
        pthread_mutex_unlock(&s->mu);
    }
    locd_engine_destroy(r.engine);
    locd_pairs_destroy(r.pairs);
    return NULL;
}
