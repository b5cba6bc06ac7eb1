/* locd frames SCENE.aabb --moving P --frames F [--threads T] [--static S]
 *             [--pause MS] [--check] [--seed N]
 *
 * Frame to frame on a locd scene (locd/scene.h): the scene's boxes go into a
 * scene (a fraction S of them static, chosen by seed); each frame a random
 * fraction P of the others moves by a small step (frames_motion.c) and the
 * scene updates. In the same run, interleaved with the updates, a full
 * locd_engine_find_pairs on the same boxes gives the rebuild time. One JSON
 * line: medians per frame, and with --check every frame's pairs, created and
 * lost compared with a from-scratch call (exit 1 on any difference). */
#include "cli.h"
#include "json.h"
#include "frames_motion.h"

#include <locd/scene.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct frames_args {
    const char *scene;
    double moving, static_frac;
    double pause_ms; /* slept before each timed update and rebuild */
    size_t frames;
    uint32_t threads;
    uint64_t seed;
    int check;
} frames_args;

static void usage(FILE *f)
{
    fprintf(f, "usage: locd frames SCENE.aabb --moving P --frames F [--threads T] [--static S] [--pause MS] [--check]\n"
               "                   [--seed N]\n"
               "  Puts the boxes in a locd scene (fraction S static, default 0), then for F frames moves a\n"
               "  random fraction P (0..1) of the non-static boxes by up to 3%% of the mean box edge per axis\n"
               "  and updates. Prints one JSON line: update_ms and rebuild_ms (medians per frame; the rebuild\n"
               "  is a full find_pairs on the same boxes, interleaved with the updates), ratio, their means\n"
               "  (update_mean_ms, rebuild_mean_ms, ratio_mean), pairs (median per frame), created and lost\n"
               "  (totals over the frames).\n"
               "  --pause MS sleeps MS milliseconds before each timed update and rebuild, as a game's frames\n"
               "  are apart (the threads idle in between; default 0).\n"
               "  --check compares every frame with a from-scratch find (pairs, created, lost): exit 1 on a\n"
               "  difference. --threads defaults to every CPU, --seed to 1.\n");
}

static double fraction(const char *v, const char *what)
{
    char *end;
    double x = strtod(v, &end);
    if (end == v || *end || !(x >= 0.0 && x <= 1.0))
        cli_die("frames: %s must be a fraction in [0, 1], not '%s'", what, v);
    return x;
}

static void parse_args(int argc, char **argv, frames_args *a)
{
    int i, have_moving = 0, have_frames = 0;
    memset(a, 0, sizeof *a);
    a->seed = 1;
    for (i = 1; i < argc; i++) {
        const char *o = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(o, "--help") || !strcmp(o, "-h")) {
            usage(stdout);
            exit(0);
        } else if (!strcmp(o, "--check")) {
            a->check = 1;
        } else if (o[0] == '-' && o[1] == '-' && !v) {
            cli_die("frames: %s needs a value", o);
        } else if (!strcmp(o, "--moving")) {
            a->moving = fraction(argv[++i], "--moving");
            have_moving = 1;
        } else if (!strcmp(o, "--static")) {
            a->static_frac = fraction(argv[++i], "--static");
        } else if (!strcmp(o, "--frames")) {
            a->frames = cli_size_option(argv[++i], 1, 1000000, "frames: --frames must be 1..1000000");
            have_frames = 1;
        } else if (!strcmp(o, "--threads")) {
            a->threads = (uint32_t)cli_size_option(argv[++i], 1, 64, "frames: --threads must be 1..64");
        } else if (!strcmp(o, "--seed")) {
            a->seed = cli_seed_option(argv[++i], "frames");
        } else if (!strcmp(o, "--pause")) {
            a->pause_ms = (double)cli_size_option(argv[++i], 0, 60000, "frames: --pause must be 0..60000 ms");
        } else if (o[0] == '-') {
            cli_die("frames: unknown option %s (see --help)", o);
        } else if (!a->scene) {
            a->scene = o;
        } else {
            cli_die("frames: one scene only");
        }
    }
    if (!a->scene || !have_moving || !have_frames) {
        usage(stderr);
        exit(2);
    }
}

static void ok(locd_status st, const char *what)
{
    if (st != LOCD_OK)
        cli_die("frames: %s: %s", what, locd_last_error());
}

/* ---- the check: from-scratch pairs as sorted id rows ---- */

/* A pair of ids, first < second. */
typedef struct id_row {
    locd_id a, b;
} id_row;

static int cmp_row(const void *x, const void *y)
{
    const id_row *p = x, *q = y;
    if (p->a != q->a)
        return p->a < q->a ? -1 : 1;
    return (p->b > q->b) - (p->b < q->b);
}

typedef struct row_set {
    id_row *r;
    size_t n, cap;
} row_set;

static void row_push(row_set *s, locd_id a, locd_id b)
{
    if (s->n == s->cap) {
        s->cap = s->cap ? 2 * s->cap : 1024;
        if (!(s->r = realloc(s->r, s->cap * sizeof *s->r)))
            cli_die("out of memory");
    }
    s->r[s->n].a = a < b ? a : b;
    s->r[s->n].b = a < b ? b : a;
    s->n++;
}

/* The from-scratch pairs (indices) as sorted id rows, static-static pairs left out. */
static void expected_rows(const locd_pairs *p, const locd_id *ids, const uint8_t *is_static, row_set *out)
{
    const uint32_t *d = locd_pairs_data(p);
    size_t k, m = locd_pairs_count(p);
    out->n = 0;
    for (k = 0; k < m; k++)
        if (!(is_static[d[2 * k]] && is_static[d[2 * k + 1]]))
            row_push(out, ids[d[2 * k]], ids[d[2 * k + 1]]);
    qsort(out->r, out->n, sizeof *out->r, cmp_row);
}

/* Rows of a that are not in b (both sorted). */
static void difference(const row_set *a, const row_set *b, row_set *out)
{
    size_t i = 0, j = 0;
    out->n = 0;
    while (i < a->n) {
        int c = j < b->n ? cmp_row(a->r + i, b->r + j) : -1;
        if (c < 0) {
            row_push(out, a->r[i].a, a->r[i].b);
            i++;
        }
        else if (c > 0)
            j++;
        else
            i++, j++;
    }
}

/* 1 if the scene's list equals the expected rows. */
static int same(const locd_id *list, size_t count, const row_set *want, const char *what, size_t frame)
{
    size_t k;
    if (count != want->n) {
        fprintf(stderr, "locd: frames: frame %zu: %s: %zu rows, from scratch %zu\n", frame, what, count, want->n);
        return 0;
    }
    for (k = 0; k < count; k++)
        if (list[2 * k] != want->r[k].a || list[2 * k + 1] != want->r[k].b) {
            fprintf(stderr, "locd: frames: frame %zu: %s row %zu: (%llu, %llu), from scratch (%llu, %llu)\n", frame,
                    what, k, (unsigned long long)list[2 * k], (unsigned long long)list[2 * k + 1],
                    (unsigned long long)want->r[k].a, (unsigned long long)want->r[k].b);
            return 0;
        }
    return 1;
}

typedef struct checker {
    row_set prev, cur, diff;
    size_t failures;
} checker;

/* Compares the scene's last update with the from-scratch pairs in p. */
static void check_frame(checker *c, const locd_scene *s, const locd_pairs *p, const locd_id *ids,
                        const uint8_t *is_static, size_t frame)
{
    const locd_id *list;
    size_t count;
    row_set t;
    int good;
    expected_rows(p, ids, is_static, &c->cur);
    ok(locd_scene_pairs(s, &list, &count), "pairs");
    good = same(list, count, &c->cur, "pairs", frame);
    difference(&c->cur, &c->prev, &c->diff);
    ok(locd_scene_created(s, &list, &count), "created");
    good = same(list, count, &c->diff, "created", frame) && good;
    difference(&c->prev, &c->cur, &c->diff);
    ok(locd_scene_lost(s, &list, &count), "lost");
    good = same(list, count, &c->diff, "lost", frame) && good;
    c->failures += !good;
    t = c->prev;
    c->prev = c->cur;
    c->cur = t;
}

/* ---- the run ---- */

typedef struct frames_run {
    frames_args a;
    cli_scene sc;
    float *boxes;
    frames_motion m;
    locd_engine *eng;
    locd_scene *scene;
    locd_pairs *pairs;
    locd_id *ids;  /* scene id of each box */
    locd_id *mid;  /* this frame's moved ids */
    float *mbox;   /* and their boxes */
    double *t_update, *t_rebuild, *n_pairs;
    double *t_stage[4]; /* the scene's own encode, merge, sweep, events ms per frame */
    size_t rebuilt;     /* frames the scene answered by rebuilding everything */
    uint64_t created, lost;
    double first_ms;
    checker chk;
} frames_run;

/* Statics in one batch, the others in another; ids[i] is box i's id. */
static void fill_scene(frames_run *r)
{
    size_t n = r->sc.n, i, k;
    uint32_t *order = malloc((n + 1) * sizeof *order);
    float *b = malloc((6 * n + 1) * sizeof *b);
    locd_id *got = malloc((n + 1) * sizeof *got);
    locd_scene_add_options opt;
    int pass;
    if (!order || !b || !got)
        cli_die("out of memory");
    for (pass = 0; pass < 2; pass++) {
        for (i = 0, k = 0; i < n; i++)
            if (r->m.is_static[i] == (pass == 0)) {
                order[k] = (uint32_t)i;
                memcpy(b + 6 * k, r->boxes + 6 * i, 6 * sizeof(float));
                k++;
            }
        locd_scene_add_options_init(&opt);
        opt.flags = pass == 0 ? LOCD_OBJECT_STATIC : 0u;
        ok(locd_scene_add_f32(r->scene, b, k, &opt, got), "add");
        for (i = 0; i < k; i++)
            r->ids[order[i]] = got[i];
    }
    free(order);
    free(b);
    free(got);
}

static void setup(frames_run *r)
{
    locd_engine_config cfg;
    size_t n, i;
    if (cli_load_scene(r->a.scene, &r->sc) != 0)
        exit(2);
    n = r->sc.n;
    if (r->sc.f64) {
        /* Rounding is monotone: min <= max survives the conversion. */
        if (!(r->boxes = malloc((6 * n + 1) * sizeof(float))))
            cli_die("out of memory");
        for (i = 0; i < 6 * n; i++)
            r->boxes[i] = (float)r->sc.d[i];
    } else {
        r->boxes = r->sc.f;
    }
    if (frames_motion_init(&r->m, r->boxes, n, r->a.static_frac, r->a.moving, r->a.seed) != 0)
        cli_die("out of memory");
    locd_engine_config_init(&cfg);
    cfg.threads = r->a.threads;
    ok(locd_engine_create(&cfg, &r->eng), "engine");
    ok(locd_scene_create(r->eng, NULL, &r->scene), "scene");
    ok(locd_pairs_create(NULL, &r->pairs), "pairs");
    r->ids = malloc((n + 1) * sizeof *r->ids);
    r->mid = malloc((r->m.moved + 1) * sizeof *r->mid);
    r->mbox = malloc((6 * r->m.moved + 1) * sizeof *r->mbox);
    r->t_update = malloc(r->a.frames * sizeof(double));
    r->t_rebuild = malloc(r->a.frames * sizeof(double));
    r->n_pairs = malloc(r->a.frames * sizeof(double));
    if (!r->ids || !r->mid || !r->mbox || !r->t_update || !r->t_rebuild || !r->n_pairs)
        cli_die("out of memory");
    for (i = 0; i < 4; i++)
        if (!(r->t_stage[i] = malloc(r->a.frames * sizeof(double))))
            cli_die("out of memory");
}

static double rebuild(frames_run *r)
{
    double t0;
    if (r->a.pause_ms > 0)
        cli_sleep_ms(r->a.pause_ms);
    t0 = cli_now_ms();
    ok(locd_engine_find_pairs_f32(r->eng, r->boxes, r->sc.n, 0, r->pairs), "rebuild");
    return cli_now_ms() - t0;
}

/* The moves and the update of one frame, timed together (what a caller pays). */
static double update(frames_run *r)
{
    size_t k;
    double t0;
    for (k = 0; k < r->m.moved; k++) {
        uint32_t i = r->m.dynamic[k];
        r->mid[k] = r->ids[i];
        memcpy(r->mbox + 6 * k, r->boxes + 6 * (size_t)i, 6 * sizeof(float));
    }
    if (r->a.pause_ms > 0)
        cli_sleep_ms(r->a.pause_ms);
    t0 = cli_now_ms();
    ok(locd_scene_move_f32(r->scene, r->mid, r->mbox, r->m.moved), "move");
    ok(locd_scene_update(r->scene, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS), "update");
    return cli_now_ms() - t0;
}

static void run_frames(frames_run *r)
{
    size_t f, count;
    const locd_id *list;
    double t0 = cli_now_ms();
    /* Frame 0 finds every pair (all of them created): reported apart. */
    ok(locd_scene_update(r->scene, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS), "update");
    r->first_ms = cli_now_ms() - t0;
    if (r->a.check) {
        rebuild(r);
        check_frame(&r->chk, r->scene, r->pairs, r->ids, r->m.is_static, 0);
    }
    for (f = 0; f < r->a.frames; f++) {
        frames_motion_step(&r->m, r->boxes);
        /* Alternate the order, so that neither side always runs on a warm cache. */
        if (f % 2) {
            r->t_rebuild[f] = rebuild(r);
            r->t_update[f] = update(r);
        } else {
            r->t_update[f] = update(r);
            r->t_rebuild[f] = rebuild(r);
        }
        {
            locd_scene_stats ss;
            locd_scene_stats_init(&ss);
            ok(locd_scene_get_stats(r->scene, &ss), "stats");
            r->t_stage[0][f] = ss.ms_encode;
            r->t_stage[1][f] = ss.ms_merge;
            r->t_stage[2][f] = ss.ms_sweep;
            r->t_stage[3][f] = ss.ms_events;
            r->rebuilt += ss.rebuilt != 0;
        }
        ok(locd_scene_pairs(r->scene, &list, &count), "pairs");
        r->n_pairs[f] = (double)count;
        ok(locd_scene_created(r->scene, &list, &count), "created");
        r->created += count;
        ok(locd_scene_lost(r->scene, &list, &count), "lost");
        r->lost += count;
        if (r->a.check)
            check_frame(&r->chk, r->scene, r->pairs, r->ids, r->m.is_static, f + 1);
    }
}

static void report(frames_run *r)
{
    locd_scene_stats ss;
    char cpu[256];
    const char *kernel = getenv("LOCD_KERNEL");
    size_t nstatic = r->sc.n - r->m.ndynamic;
    double up = cli_median(r->t_update, r->a.frames), rb = cli_median(r->t_rebuild, r->a.frames);
    /* the means too: a scene's near-pair list is built again every few frames (docs/scene.md) */
    const double up_mean = cli_mean(r->t_update, r->a.frames), rb_mean = cli_mean(r->t_rebuild, r->a.frames);
    locd_scene_stats_init(&ss);
    ok(locd_scene_get_stats(r->scene, &ss), "stats");
    cli_cpu_model(cpu, sizeof cpu);
    printf("{\"n\":%zu,\"static\":%zu,\"static_fraction\":%.4g,\"moving\":%.4g,\"moved_per_frame\":%zu,"
           "\"frames\":%zu,\"threads\":%u,\"seed\":%llu,\"step\":%.6g,"
           "\"update_ms\":%.4f,\"rebuild_ms\":%.4f,\"ratio\":%.4f,"
           "\"update_mean_ms\":%.4f,\"rebuild_mean_ms\":%.4f,\"ratio_mean\":%.4f,\"first_update_ms\":%.3f,"
           "\"pairs\":%.0f,\"created\":%llu,\"lost\":%llu,"
           "\"counts\":\"pairs: median per frame; created, lost: totals over the frames\","
           "\"scene_ms\":{\"encode\":%.4f,\"merge\":%.4f,\"sweep\":%.4f,\"events\":%.4f},\"rebuilt_frames\":%zu,"
           "\"checked\":%s,\"failed_frames\":%zu,\"cpu\":",
           r->sc.n, nstatic, r->a.static_frac, r->a.moving, r->m.moved, r->a.frames, ss.threads,
           (unsigned long long)r->a.seed, r->m.step, up, rb, rb > 0.0 ? up / rb : 0.0,
           up_mean, rb_mean, rb_mean > 0.0 ? up_mean / rb_mean : 0.0, r->first_ms,
           cli_median(r->n_pairs, r->a.frames), (unsigned long long)r->created, (unsigned long long)r->lost,
           cli_median(r->t_stage[0], r->a.frames), cli_median(r->t_stage[1], r->a.frames),
           cli_median(r->t_stage[2], r->a.frames), cli_median(r->t_stage[3], r->a.frames), r->rebuilt,
           r->a.check ? "true" : "false", r->chk.failures);
    json_write_string(stdout, cpu);
    printf(",\"kernel\":");
    json_write_string(stdout, kernel && *kernel ? kernel : "auto");
    printf("}\n");
}

static void close_run(frames_run *r)
{
    locd_scene_destroy(r->scene);
    locd_pairs_destroy(r->pairs);
    locd_engine_destroy(r->eng);
    frames_motion_free(&r->m);
    if (r->boxes != r->sc.f)
        free(r->boxes);
    cli_free_scene(&r->sc);
    free(r->ids);
    free(r->mid);
    free(r->mbox);
    free(r->t_update);
    free(r->t_rebuild);
    free(r->n_pairs);
    free(r->t_stage[0]);
    free(r->t_stage[1]);
    free(r->t_stage[2]);
    free(r->t_stage[3]);
    free(r->chk.prev.r);
    free(r->chk.cur.r);
    free(r->chk.diff.r);
}

int cmd_frames(int argc, char **argv)
{
    frames_run r;
    int rc;
    memset(&r, 0, sizeof r);
    parse_args(argc, argv, &r.a);
    setup(&r);
    fill_scene(&r);
    run_frames(&r);
    report(&r);
    rc = r.chk.failures ? 1 : 0;
    if (rc)
        fprintf(stderr, "locd: frames: %zu of %zu frames differ from a from-scratch find\n", r.chk.failures,
                r.a.frames + 1);
    close_run(&r);
    return rc;
}
