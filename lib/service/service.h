/* Level 3: the service's wire protocol, shared by the client
 * (client*.c) and the server (server*.c); then the client's own types, then
 * the server's.
 *
 * Every message is a 24-byte header followed by `length` payload bytes:
 *   u32 magic "LCDS" | u16 version | u16 type | u64 job id | u64 length
 * All integers little-endian; box coordinates and pairs are sent as raw
 * little-endian float32/float64/uint32 arrays (both ends are little-endian
 * machines; lc_proto_host_ok() checks). A header with a bad magic, version
 * or type, or a length over the receiver's limit, drops the connection.
 *
 * HELLO   c->s  u32 secret_len, secret bytes
 * WELCOME s->c  u32 shm_ok (1: the client may pass boxes through /dev/shm)
 * SUBMIT  c->s  u32 flags, u32 f64, u64 n, u32 max_depth, i32 cell_bias,
 *               u32 config_flags, u32 transport; transport 0: the boxes
 *               follow (n*6 values); 1: u32 name_len, a shm segment name
 * CANCEL  c->s  (no payload) cancels job `id`
 * RESULT  s->c  i32 status, i64 error_index, u32 msg_len, msg, stats
 *               (LC_PROTO_STATS_BYTES), u64 count, count pairs (2 u32 each)
 * ERROR   s->c  i32 status, u32 msg_len, msg; the server then closes */
#ifndef LOCD_SERVICE_PROTO_H
#define LOCD_SERVICE_PROTO_H

#include "engine/engine.h"
#include "locd/service.h"

#include <pthread.h>

#define LC_PROTO_MAGIC 0x5344434cu /* "LCDS" as little-endian bytes */
#define LC_PROTO_VERSION 1u
#define LC_PROTO_HEADER 24

#define LC_MSG_HELLO 1
#define LC_MSG_WELCOME 2
#define LC_MSG_SUBMIT 3
#define LC_MSG_CANCEL 4
#define LC_MSG_RESULT 5
#define LC_MSG_ERROR 6

#define LC_PROTO_SUBMIT_FIXED 36
#define LC_PROTO_RESULT_FIXED 16 /* status, error index, message length */
#define LC_PROTO_ERROR_FIXED 8   /* status, message length */
#define LC_PROTO_STATS_BYTES 112
#define LC_PROTO_BOX_VALUES 6 /* min x, y, z, max x, y, z */
#define LC_PROTO_PAIR_BYTES 8 /* two u32 */
#define LC_PROTO_MAX_TEXT 1024
#define LC_PROTO_MAX_SECRET 1024
/* Boxes at least this large go through shared memory on a local socket. */
#define LC_PROTO_SHM_MIN_BYTES (64u * 1024u)
/* Segment names the server accepts: "/locd-" + [A-Za-z0-9-] (the names
 * lc_shm_unique_name makes). */
#define LC_PROTO_SHM_PREFIX LC_SHM_PREFIX
/* Jobs one client connection keeps in flight at most: a submit past it
 * waits for one to finish. Not above the service's default max_jobs. */
#define LC_CLIENT_MAX_IN_FLIGHT 1024u
/* A message that has started must arrive (or be written) within this. */
#define LC_MSG_TIMEOUT_MS 30000

typedef struct lc_msg_header {
    uint32_t magic;
    uint16_t version;
    uint16_t type;
    uint64_t id;
    uint64_t length;
} lc_msg_header;

typedef struct lc_submit_fixed {
    uint32_t flags, f64;
    uint64_t n;
    uint32_t max_depth;
    int32_t cell_bias;
    uint32_t config_flags, transport;
} lc_submit_fixed;

int lc_proto_host_ok(void);

void lc_put_u32(uint8_t *p, uint32_t v);
void lc_put_u64(uint8_t *p, uint64_t v);
uint32_t lc_get_u32(const uint8_t *p);
uint64_t lc_get_u64(const uint8_t *p);

void lc_proto_put_header(uint8_t *out, uint16_t type, uint64_t id, uint64_t length);
/* 1 when valid; otherwise 0 with the reason in why. */
int lc_proto_get_header(const uint8_t *in, uint64_t max_length, lc_msg_header *h, char *why, size_t why_len);

void lc_proto_put_submit(uint8_t *out, const lc_submit_fixed *s);
void lc_proto_get_submit(const uint8_t *in, lc_submit_fixed *s);
void lc_proto_put_stats(uint8_t *out, const locd_stats *s);
void lc_proto_get_stats(const uint8_t *in, locd_stats *s);

/* Writes all bytes (MSG_NOSIGNAL: a closed peer is an error, not SIGPIPE).
 * 1 on success, 0 on error (errno). */
int lc_proto_write_all(int fd, const void *buf, size_t len);
/* lc_proto_read_all with one total deadline (an lc_now_ms() value; < 0 =
 * none) for all len bytes, not one per wait: a peer that trickles a byte
 * at a time cannot stretch it. Same return values. */
int lc_proto_read_by(int fd, void *buf, size_t len, double deadline, char *why, size_t why_len);
/* lc_proto_write_all with a total deadline (< 0 = none): 1, or 0 (errno
 * ETIMEDOUT when the deadline passed). */
int lc_proto_write_by(int fd, const void *buf, size_t len, double deadline);
/* Reads exactly len bytes. timeout_ms < 0 waits forever; otherwise each
 * wait for more bytes is bounded. Returns 1 on success; on failure (why), 0
 * for a clean end of stream before the first byte and -1 for anything else
 * (error, truncation, timeout). The exception to the 1/0 convention: the
 * service's connection reader tells a client that left from one that broke. */
int lc_proto_read_all(int fd, void *buf, size_t len, int timeout_ms, char *why, size_t why_len);
/* Reads and drops len bytes. 1 on success, 0 on failure (why). */
int lc_proto_skip(int fd, uint64_t len, int timeout_ms, char *why, size_t why_len);

/* Parses "unix:PATH" or "tcp:HOST:PORT". 1 on success, 0 (why) when
 * malformed. */
typedef struct lc_address {
    int tcp;
    char path[108];
    char host[256];
    char port[16];
} lc_address;
int lc_proto_parse_address(const char *s, lc_address *a, char *why, size_t why_len);

/* Constant-time comparison of two secrets (1 when equal). */
int lc_proto_secret_equal(const char *a, size_t alen, const char *b, size_t blen);

/* ---- level 3 client ----
 * client.c: the backend table and the synchronous find;
 * client_conn.c: connecting, the connection's references, reconnecting;
 * client_reader.c: the reader thread, which finishes jobs from RESULTs;
 * client_jobs.c: service jobs and their submit. */

/* A service job: the common part first (see engine/engine.h), then what
 * the connection needs to match the service's answer. */
typedef struct lc_svc_job {
    locd_job job;
    struct lc_svc_conn *conn;
    uint64_t id;
    char shm_name[64];       /* bulk input segment to unlink when done ("" = none) */
    double deadline;         /* lc_now_ms() past which the job fails with LOCD_ERR_TIMEOUT; 0 = none */
    struct lc_svc_job *next; /* in the connection's pending list */
} lc_svc_job;

typedef struct lc_svc_conn {
    pthread_mutex_t mu; /* refs, dead, closing, pending, next_id */
    int refs;
    int dead;
    int closing; /* this side is closing the connection (engine destroyed) */
    char why[200];
    lc_svc_job *pending;
    uint64_t next_id;
    pthread_mutex_t wmu; /* one writer at a time; fd */
    int fd;
    int shm_ok;
    int wake;           /* eventfd: a job with an earlier deadline than the reader's wait arrived */
    double reader_next; /* under mu: when the reader wakes up next to check deadlines (0 = never) */
    int msg_timeout;    /* reader thread: the current message's per-stall bound in ms */
    pthread_t reader;
    locd_allocator alloc;
} lc_svc_conn;

/* lc_backend.open / close: the engine's connection. */
locd_status lc_svc_open(locd_engine *e);
void lc_svc_close(locd_engine *e);
/* The engine's per-job deadline base in ms (config service_timeout_ms, 0
 * = LOCD_DEFAULT_SERVICE_TIMEOUT_MS); negative = no deadline. */
int64_t lc_svc_timeout_ms(const locd_engine *e);
/* The live connection with a reference for the caller, reconnecting once
 * when the last one broke. */
locd_status lc_svc_get_conn(locd_engine *e, lc_svc_conn **out);
/* Drops one reference; the last one closes and frees the connection. */
void lc_svc_conn_unref(lc_svc_conn *c);
/* The connection's reader thread (arg: the lc_svc_conn). */
void *lc_svc_reader_main(void *arg);
/* Removes job `id` from the pending list; the caller gets its reference. */
lc_svc_job *lc_svc_take_pending(lc_svc_conn *c, uint64_t id);
/* Finishes a job, unlinking its input segment, and drops the runner's
 * reference. */
void lc_svc_job_done(lc_svc_job *j, locd_status st, const char *msg, int64_t index);
/* Called with c->mu held, after j joined the pending list: 1 when the
 * reader must be woken (c->wake) because j's deadline comes before its
 * next check. The reader finishes overdue jobs with LOCD_ERR_TIMEOUT. */
int lc_svc_deadline_added_locked(lc_svc_conn *c, const lc_svc_job *j);
/* lc_backend.submit. */
locd_status lc_svc_submit(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags, locd_job **out);

/* ==== The service (server*.c); nothing here is the client's business ====
 *
 * Files, from the bottom up (each calls only the ones before it):
 *   server_conn.c     the log; writing on a connection (RESULT, ERROR); its references
 *   server_jobs.c     the run queue, the runner threads, cancelling
 *   server_input.c    reading a SUBMIT: inline boxes or the client's shm segment
 *   server_session.c  one connection: accepting it, HELLO/WELCOME, its messages
 *   server_listen.c   the listening socket (unix or tcp)
 *   server.c          the locd_service handle: create/run/stop/destroy */

/* locd_service_config defaults (for 0) and caps; docs/levels.md, "Limits
 * and deadlines", lists them. The HELLO is short: a client that cannot send
 * it within the auth deadline is not one. */
#define LC_HELLO_TIMEOUT_MS 5000
#define LC_SRV_DEFAULT_MESSAGE_MS LC_MSG_TIMEOUT_MS
#define LC_SRV_DEFAULT_SEND_MS 30000
#define LC_SRV_DEFAULT_JOB_MS 600000
#define LC_SRV_DEFAULT_JOB_BOXES (1ull << 26)
#define LC_SRV_DEFAULT_JOB_PAIRS (1ull << 27)
#define LC_SRV_DEFAULT_JOB_MEMORY (4ull << 30)
#define LC_SRV_DEFAULT_CLIENT_BOXES (1ull << 27)
#define LC_SRV_DEFAULT_CLIENT_PAIRS (1ull << 28)
#define LC_SRV_DEFAULT_CLIENT_MEMORY (8ull << 30)
/* A runner keeps at most this much of its engine's memory between jobs:
 * a huge job's buffers are given back once its result is sent. */
#define LC_SRV_KEEP_BYTES (64ull << 20)
/* After accept fails for want of descriptors or memory, the listener
 * rests this long before trying again (instead of spinning). */
#define LC_SRV_ACCEPT_BACKOFF_MS 100
/* A full service breaks its oldest unauthenticated connection to admit a
 * new one, while at most this many broken ones are still leaving. */
#define LC_SRV_MAX_EVICTING 16u
#define LC_SRV_MAX_THREADS 256
#define LC_SRV_DEFAULT_MAX_MESSAGE (1ull << 30)
#define LC_SRV_DEFAULT_MAX_CLIENTS 256
#define LC_SRV_DEFAULT_MAX_JOBS 1024
#define LC_SRV_LISTEN_BACKLOG 128
/* Longest segment name a SUBMIT may carry (the client's names are ~45). */
#define LC_SRV_MAX_SHM_NAME 60

typedef struct lc_server lc_server;
typedef struct lc_srv_conn lc_srv_conn;

typedef struct lc_srv_job {
    struct lc_srv_job *qnext;         /* run queue */
    struct lc_srv_job *cnext, *cprev; /* the connection's jobs */
    lc_srv_conn *c;
    uint64_t id;
    int cancelled; /* atomic: the client cancelled it or went away */
    lc_submit_fixed f;
    void *boxes;
    size_t bytes;
    uint64_t pairs_seen; /* runner only: pairs counted into c->pairs_running */
    int answered;        /* under s->mu: its RESULT is on the way (no longer counts in c->njobs) */
} lc_srv_job;

struct lc_srv_conn {
    lc_server *s;
    int fd;
    int refs;   /* under s->mu: the connection thread + each job */
    int closed; /* under wmu: no more writes */
    pthread_mutex_t wmu;
    lc_srv_job *jobs; /* under s->mu */
    uint32_t njobs;
    uint64_t boxes_in_flight; /* under s->mu: boxes of its queued and running jobs */
    uint64_t bytes_in_flight; /* atomic: their box data + their engines' memory */
    uint64_t pairs_running;   /* atomic: pairs found so far by its running jobs */
    int shm_ok;
    int authed;       /* under s->mu: past the handshake */
    double since;     /* lc_now_ms() at accept */
    double deadline;  /* connection thread only: the current message's */
    char peer[96];
    lc_srv_conn *next; /* s->conns */
};

/* The state behind a locd_service handle (server.c says why the handle
 * wraps it rather than being it). */
struct lc_server {
    uint32_t magic;
    locd_service_config cfg;
    char *secret;
    char address[300];
    char unix_path[108];
    int lfd;
    int wake[2];
    pthread_mutex_t mu;
    pthread_cond_t cv;       /* queue not empty / stopping */
    pthread_cond_t conns_cv; /* a connection ended */
    lc_srv_job *qhead, *qtail;
    lc_srv_conn *conns;
    uint32_t nconns;
    int stopping;
    int accept_failing; /* accept thread only: the last accept ran out of descriptors */
    pthread_t *runners;
    uint32_t nrunners;
    uint64_t served;
    double auth_window;   /* under mu: start of the current second of secret checks (server_auth.c) */
    uint32_t auth_fails;  /* under mu: wrong secrets in it */
    uint32_t auth_fail_delay_ms; /* LC_AUTH_FAIL_DELAY_MS (0 in the fuzz harness, which checks many secrets) */
    int auth_logged;      /* under mu: the throttle was logged in it */
};

/* server_conn.c */
void lc_srv_log(const lc_server *s, int32_t sev, const char *fmt, ...) LC_PRINTF(3, 4);
/* Writes a then b (blen may be 0) as one message. 1 on success, 0 when the
 * connection is closed or breaks (it is then shut down for its reader to
 * notice). */
int lc_srv_send(lc_srv_conn *c, const void *a, size_t alen, const void *b, size_t blen);
void lc_srv_send_result(lc_srv_conn *c, uint64_t id, locd_status st, const char *msg, int64_t index,
                        const locd_stats *stats, const uint32_t *pairs, size_t count);
/* Escapes the first len bytes of client-supplied text for the log:
 * printable ASCII is kept, every other byte (and backslash) becomes \xHH,
 * so a client cannot forge log lines. out gets at most out_len - 1 chars. */
void lc_srv_escape(const char *in, size_t len, char *out, size_t out_len);
/* An ERROR on a socket that has no connection (yet); best effort. */
void lc_srv_send_error(int fd, locd_status st, const char *msg);
/* Under s->mu; frees the connection with its last reference. */
void lc_srv_conn_unref_locked(lc_srv_conn *c);

/* server_jobs.c */
void lc_srv_job_free(lc_srv_job *j);
/* Counts j against the connection's and the job's limits and links it to
 * the connection: LOCD_OK, or LOCD_ERR_LIMIT (why) when it is over one (j
 * is then the caller's to answer and free; the connection goes on). */
locd_status lc_srv_admit(lc_srv_conn *c, lc_srv_job *j, char *why, size_t wl);
/* Unlinks an admitted job from its connection and frees it. */
void lc_srv_job_retire(lc_srv_job *j);
/* Queues an admitted job for the runners. */
void lc_srv_enqueue(lc_srv_conn *c, lc_srv_job *j);
void lc_srv_cancel(lc_srv_conn *c, uint64_t id);
/* Under s->mu: marks every job of the connection cancelled. */
void lc_srv_cancel_all_locked(lc_srv_conn *c);
/* A runner thread: runs queued jobs until the service stops. */
void *lc_srv_runner_main(void *service);
/* Runs the queued jobs on the caller's thread until the queue is empty
 * (tests/fuzz/fuzz_session.c: a running service stops its jobs). */
void lc_srv_run_queued(lc_server *s);

/* server_input.c */
/* Reads a SUBMIT payload. 1 when the connection is fine, with the job in
 * *out, or NULL there when the job was refused (an error result was sent);
 * 0 to drop the connection (why). */
int lc_srv_read_submit(lc_srv_conn *c, const lc_msg_header *h, lc_srv_job **out, char *why, size_t wl);

/* server_auth.c */
#define LC_AUTH_MIN_SECRET 16      /* shorter secrets are logged as a warning (locd serve refuses them) */
#define LC_AUTH_FAIL_DELAY_MS 1000 /* a wrong secret is answered after this */
#define LC_AUTH_MAX_FAILS 10       /* wrong secrets checked per second, service-wide */
#define LC_AUTH_OK 1
#define LC_AUTH_WRONG 0     /* answered after LC_AUTH_FAIL_DELAY_MS */
#define LC_AUTH_THROTTLED -1 /* not checked: too many wrong secrets this second */
/* Checks a client's secret (LC_AUTH_OK when the service has none). */
int lc_srv_auth_check(lc_server *s, const uint8_t *secret, size_t len);
/* Logs a short secret and a TCP bind to every interface. */
void lc_srv_warn_exposure(const lc_server *s, const lc_address *a);

/* server_session.c */
/* Accepts one connection on s->lfd and starts its thread. 1 when the
 * listener may be polled again at once, 0 when accept ran out of
 * descriptors or memory (the caller backs off). */
int lc_srv_accept(lc_server *s);
/* One connection's session loop on the caller's thread (no clean-up). */
void lc_srv_serve(lc_srv_conn *c);

/* server_listen.c */
/* Binds and listens on a, filling s->lfd, s->address (and s->unix_path). */
locd_status lc_srv_listen(lc_server *s, const lc_address *a);

#endif
