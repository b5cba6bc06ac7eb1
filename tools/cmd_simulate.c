/* locd simulate SCENE.json --steps N: advances a JSON scene through the
 * filter pipeline (only the stages and effects the scene declares), prints
 * one JSON line of per-stage statistics per step and a summary line, and
 * optionally renders PNG frames or a GIF through scripts/render_scene.py. */
#include "cli.h"
#include "json.h"
#include "sim_scene.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#ifndef LOCD_RENDER_SCRIPT
#define LOCD_RENDER_SCRIPT "scripts/render_scene.py"
#endif
/* Where `meson install` puts the renderer: relative to the installed locd
 * (bindir/../datadir/locd, so a moved prefix still finds it), and absolute. */
#ifndef LOCD_RENDER_REL
#define LOCD_RENDER_REL "../share/locd/render_scene.py"
#endif
#ifndef LOCD_RENDER_INSTALLED
#define LOCD_RENDER_INSTALLED "/usr/local/share/locd/render_scene.py"
#endif

/* Objects drawn at most (the million-box scene is for statistics). */
#define SIM_RENDER_MAX 5000

typedef struct sim_args {
    const char *scene, *frames, *gif, *dump;
    int steps, every, quiet, ladder;
    double dt; /* 0 = as the scene says */
    int continuous; /* -1 = as the scene says */
    long threads;   /* -1 = as the scene says */
} sim_args;

static void usage(FILE *f)
{
    fprintf(f, "usage: locd simulate SCENE.json|- [--steps N] [--continuous on|off|auto] [--threads K]\n"
               "                     [--frames DIR | --gif FILE] [--every K] [--dump FILE] [--quiet]\n"
               "                     [--dt SECONDS] [--ladder]\n"
               "  Runs the scene through the pipeline; one JSON line per step on stdout (its 'stages'\n"
               "  object: calls, ms, pairs_in, pairs_out per stage), then a 'summary' line.\n"
               "  --frames/--gif record every K-th step (default 1) and render them with\n"
               "  python3 + matplotlib: render_scene.py as installed (PREFIX/share/locd), else the source\n"
               "  tree's (LOCD_PYTHON, LOCD_RENDER_SCRIPT override them). SCENE - reads stdin.\n"
               "  --dump writes the recorded positions (JSON lines) without rendering.\n"
               "  --quiet prints the summary line only. Scene format: docs/formats.md.\n"
               "  --ladder also runs, on every step's state, the pipeline as boxes only, + convex\n"
               "  exact, + mesh exact, + swept, and reports pairs and time of each (docs/accuracy-pipeline.md).\n");
}

/* --continuous's value as a LOCD_SWEPT_* mode; anything else exits. */
static int parse_continuous(const char *v)
{
    if (!strcmp(v, "on"))
        return LOCD_SWEPT_ON;
    if (!strcmp(v, "off"))
        return LOCD_SWEPT_OFF;
    if (!strcmp(v, "auto"))
        return LOCD_SWEPT_AUTO;
    cli_die("simulate: --continuous is on, off or auto");
    return 0;
}

static int parse_args(int argc, char **argv, sim_args *a)
{
    int i;
    memset(a, 0, sizeof *a);
    a->steps = -1;
    a->every = 1;
    a->continuous = -1;
    a->threads = -1;
    for (i = 1; i < argc; i++) {
        const char *o = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(o, "--help") || !strcmp(o, "-h")) {
            usage(stdout);
            exit(0);
        } else if (!strcmp(o, "--quiet")) {
            a->quiet = 1;
        } else if (!strcmp(o, "--ladder")) {
            a->ladder = 1;
        } else if (o[0] == '-' && o[1] == '-' && !v) {
            cli_die("simulate: %s needs a value", o);
        } else if (!strcmp(o, "--steps")) {
            a->steps = (int)cli_size_option(argv[++i], 0, INT_MAX, "simulate: bad --steps (0..%d)", INT_MAX);
        } else if (!strcmp(o, "--dt")) {
            a->dt = atof(argv[++i]);
            if (!(a->dt > 0.0))
                cli_die("simulate: --dt must be > 0");
        } else if (!strcmp(o, "--every")) {
            a->every = (int)cli_size_option(argv[++i], 1, INT_MAX, "simulate: bad --every (1..%d)", INT_MAX);
        } else if (!strcmp(o, "--threads")) {
            a->threads = (long)cli_size_option(argv[++i], 0, 4096, "simulate: bad --threads (0..4096)");
        } else if (!strcmp(o, "--frames")) {
            a->frames = argv[++i];
        } else if (!strcmp(o, "--gif")) {
            a->gif = argv[++i];
        } else if (!strcmp(o, "--dump")) {
            a->dump = argv[++i];
        } else if (!strcmp(o, "--continuous")) {
            a->continuous = parse_continuous(argv[++i]);
        } else if (o[0] == '-' && o[1]) { /* "-" alone is the scene on stdin */
            cli_die("simulate: unknown option %s (see --help)", o);
        } else if (!a->scene) {
            a->scene = o;
        } else {
            cli_die("simulate: one scene only");
        }
    }
    if (!a->scene) {
        usage(stderr);
        return -1;
    }
    if (a->every < 1)
        a->every = 1;
    return 0;
}

static const char *swept_name(int mode)
{
    return mode == LOCD_SWEPT_ON ? "on" : mode == LOCD_SWEPT_OFF ? "off" : "auto";
}

static void print_stage(FILE *f, const char *name, const locd_stage_stats *s, int last)
{
    fprintf(f, "\"%s\":{\"calls\":%llu,\"ms\":%.4f,\"pairs_in\":%llu,\"pairs_out\":%llu,\"tests\":%llu}%s", name,
            (unsigned long long)s->calls, s->ms, (unsigned long long)s->pairs_in, (unsigned long long)s->pairs_out,
            (unsigned long long)s->tests, last ? "" : ",");
}

static void print_stages(FILE *f, const locd_pipeline_stats *s)
{
    fputs("\"stages\":{", f);
    print_stage(f, "broad", &s->broad, 0);
    print_stage(f, "shape", &s->shape, 0);
    print_stage(f, "swept", &s->swept, 0);
    print_stage(f, "contact", &s->contact, 1);
    fprintf(f, "},\"tests\":{\"closed\":%llu,\"ccd\":%llu,\"fcl\":%llu}", (unsigned long long)s->tests_closed,
            (unsigned long long)s->tests_ccd, (unsigned long long)s->tests_fcl);
}

static void add_stage(locd_stage_stats *acc, const locd_stage_stats *s)
{
    acc->calls += s->calls;
    acc->ms += s->ms;
    acc->pairs_in += s->pairs_in;
    acc->pairs_out += s->pairs_out;
    acc->tests += s->tests;
}

static void accumulate(locd_pipeline_stats *acc, const locd_pipeline_stats *s)
{
    add_stage(&acc->broad, &s->broad);
    add_stage(&acc->shape, &s->shape);
    add_stage(&acc->swept, &s->swept);
    add_stage(&acc->contact, &s->contact);
    acc->tests_closed += s->tests_closed;
    acc->tests_ccd += s->tests_ccd;
    acc->tests_fcl += s->tests_fcl;
    acc->ms_total += s->ms_total;
}

/* ---- simple response: equal masses, restitution, push-apart ---- */

typedef struct sim_state {
    sim_scene *sc;
    double *frac;   /* fraction of the step travelled before a swept impact */
    double *vold;   /* velocities before the response (3 per object) */
    uint32_t *hits; /* contacts per object over the run */
    double *min_z;
} sim_state;

static void respond(sim_state *st, const locd_contacts *c)
{
    sim_scene *s = st->sc;
    size_t k, m = locd_contacts_count(c);
    const uint32_t *pairs = locd_contacts_pairs(c);
    const double *toi = locd_contacts_toi(c), *depth = locd_contacts_depth(c), *normal = locd_contacts_normal(c);
    for (k = 0; k < m; k++) {
        uint32_t i = pairs[2 * k], j = pairs[2 * k + 1];
        st->hits[i]++;
        st->hits[j]++;
    }
    if (!s->response || !normal)
        return;
    for (k = 0; k < m; k++) {
        uint32_t i = pairs[2 * k], j = pairs[2 * k + 1];
        double wi = s->dynamic[i], wj = s->dynamic[j], *vi = s->vel + 6 * (size_t)i, *vj = s->vel + 6 * (size_t)j;
        const double *n = normal + 3 * k;
        double vn;
        int a;
        if (wi + wj == 0.0)
            continue;
        vn = (vj[0] - vi[0]) * n[0] + (vj[1] - vi[1]) * n[1] + (vj[2] - vi[2]) * n[2];
        if (vn < 0.0) {
            double J = -(1.0 + s->restitution) * vn / (wi + wj);
            for (a = 0; a < 3; a++) {
                vi[a] -= J * wi * n[a];
                vj[a] += J * wj * n[a];
            }
        }
        if (toi[k] > 0.0) {
            if (wi > 0.0 && toi[k] < st->frac[i])
                st->frac[i] = toi[k];
            if (wj > 0.0 && toi[k] < st->frac[j])
                st->frac[j] = toi[k];
        } else {
            /* Push apart 80% of the depth beyond a small slop. */
            double corr = fmax(depth[k] - 1e-4, 0.0) * 0.8 / (wi + wj);
            for (a = 0; a < 3; a++) {
                s->poses[7 * (size_t)i + a] -= corr * wi * n[a];
                s->poses[7 * (size_t)j + a] += corr * wj * n[a];
            }
        }
    }
}

static void integrate(sim_state *st)
{
    sim_scene *s = st->sc;
    size_t i;
    int a;
    for (i = 0; i < s->n; i++) {
        double *p = s->poses + 7 * i, *v = s->vel + 6 * i;
        if (!s->dynamic[i])
            continue;
        if (st->frac[i] < 1.0) {
            /* Travel to the impact, then on with the new velocity. */
            for (a = 0; a < 3; a++)
                p[a] += st->vold[3 * i + a] * s->dt * st->frac[i] + v[a] * s->dt * (1.0 - st->frac[i]);
            st->frac[i] = 1.0;
        } else {
            for (a = 0; a < 3; a++)
                p[a] += v[a] * s->dt;
        }
        if (p[2] < st->min_z[i])
            st->min_z[i] = p[2];
    }
}

/* ---- recording and rendering ---- */

static void write_header(FILE *f, const sim_scene *s)
{
    size_t i, k, n = s->n < SIM_RENDER_MAX ? s->n : SIM_RENDER_MAX;
    fprintf(f, "{\"header\":{\"scene\":");
    json_write_string(f, s->name);
    fprintf(f, ",\"dt\":%.9g,\"objects\":%zu,\"shown\":%zu,\"shape_of\":[", s->dt, s->n, n);
    for (i = 0; i < n; i++)
        fprintf(f, "%s%u", i ? "," : "", s->shape_of[i]);
    fputs("],\"static\":[", f);
    for (i = 0; i < n; i++)
        fprintf(f, "%s%d", i ? "," : "", !s->dynamic[i]);
    fputs("],\"shapes\":[", f);
    for (k = 0; k < s->nshapes; k++) {
        const sim_shape *sh = &s->shapes[k];
        fprintf(f, "%s{\"kind\":\"%s\",\"radius\":%.9g,\"half\":[%.9g,%.9g,%.9g],\"points\":[", k ? "," : "",
                sim_kind_name(sh->kind), sh->radius, sh->half[0], sh->half[1], sh->half[2]);
        for (i = 0; i < 3 * sh->npoints; i++)
            fprintf(f, "%s%.6g", i ? "," : "", sh->points[i]);
        fputs("],\"triangles\":[", f);
        for (i = 0; i < 3 * sh->ntris; i++)
            fprintf(f, "%s%u", i ? "," : "", sh->tris[i]);
        fputs("]}", f);
    }
    fputs("]}}\n", f);
}

static void write_positions(FILE *f, const sim_scene *s, int step)
{
    size_t i, n = s->n < SIM_RENDER_MAX ? s->n : SIM_RENDER_MAX;
    fprintf(f, "{\"step\":%d,\"t\":%.6g,\"p\":[", step, step * s->dt);
    for (i = 0; i < n; i++) {
        const double *p = s->poses + 7 * i;
        fprintf(f, "%s%.5g,%.5g,%.5g,%.5g,%.5g,%.5g,%.5g", i ? "," : "", p[0], p[1], p[2], p[3], p[4], p[5], p[6]);
    }
    fputs("]}\n", f);
}

/* The renderer: $LOCD_RENDER_SCRIPT, else the installed one beside this
 * executable (../share/locd/ from its directory), else the install
 * prefix's, else the source tree's (an uninstalled build). */
static const char *find_renderer(char *buf, size_t len)
{
    const char *env = getenv("LOCD_RENDER_SCRIPT");
    ssize_t n;
    char *slash;
    if (env && *env)
        return env;
    n = readlink("/proc/self/exe", buf, len - 1);
    if (n > 0) {
        buf[n] = '\0';
        if ((slash = strrchr(buf, '/')) != NULL && (size_t)(slash - buf) + 1 + sizeof LOCD_RENDER_REL <= len) {
            memcpy(slash + 1, LOCD_RENDER_REL, sizeof LOCD_RENDER_REL);
            if (access(buf, R_OK) == 0)
                return buf;
        }
    }
    if (access(LOCD_RENDER_INSTALLED, R_OK) == 0)
        return LOCD_RENDER_INSTALLED;
    return LOCD_RENDER_SCRIPT;
}

static int render(const char *dump, const sim_args *a)
{
    const char *py = getenv("LOCD_PYTHON");
    char found[4096];
    const char *script = find_renderer(found, sizeof found);
    char *argv[6];
    pid_t pid;
    int status;
    argv[0] = (char *)(py && *py ? py : "python3");
    argv[1] = (char *)script;
    argv[2] = (char *)dump;
    argv[3] = (char *)(a->gif ? "--gif" : "--frames");
    argv[4] = (char *)(a->gif ? a->gif : a->frames);
    argv[5] = NULL;
    fflush(stdout);
    pid = fork();
    if (pid < 0)
        return -1;
    if (pid == 0) {
        /* The renderer's progress goes to stderr: stdout stays JSON lines. */
        dup2(2, 1);
        execvp(argv[0], argv);
        fprintf(stderr, "locd: cannot run %s: %s\n", argv[0], strerror(errno));
        _exit(127);
    }
    if (waitpid(pid, &status, 0) < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        fprintf(stderr, "locd: rendering failed; the positions are in %s (run: %s %s %s %s %s)\n", dump, argv[0],
                argv[1], dump, argv[3], argv[4]);
        return -1;
    }
    return 0;
}

/* ---- accuracy ladder: the same state through more and more stages ---- */

#define LADDER_RUNGS 4
static const char *const ladder_names[LADDER_RUNGS] = {"boxes", "convex", "mesh", "swept"};

typedef struct ladder_totals {
    uint64_t pairs[LADDER_RUNGS];
    double ms[LADDER_RUNGS];
    uint64_t swept_late;   /* swept hits inside the step that discrete stepping finds at the next step */
    uint64_t swept_missed; /* swept hits that no longer overlap at the step's end: discrete misses them */
} ladder_totals;

static void ladder_options(const locd_pipeline_options *base, int rung, locd_pipeline_options *o)
{
    int k;
    *o = *base;
    o->stages = rung == 0 ? 0u : LOCD_STAGE_SHAPE;
    o->swept = rung == 3 ? LOCD_SWEPT_ON : LOCD_SWEPT_OFF;
    if (rung == 1)
        for (k = 1; k <= LOCD_SHAPE_MESH; k++)
            locd_pipeline_options_route(o, LOCD_SHAPE_MESH, k, LOCD_ROUTE_BOX);
}

/* 1 if objects i and j still overlap at the end of the step. */
static int overlap_at_end(const sim_scene *s, uint32_t i, uint32_t j)
{
    double pi[7], pj[7];
    int32_t hit = 0;
    int a;
    memcpy(pi, s->poses + 7 * (size_t)i, sizeof pi);
    memcpy(pj, s->poses + 7 * (size_t)j, sizeof pj);
    for (a = 0; a < 3; a++) {
        pi[a] += s->vel[6 * (size_t)i + a] * s->dt;
        pj[a] += s->vel[6 * (size_t)j + a] * s->dt;
    }
    locd_shape_collide(s->shapes[s->shape_of[i]].handle, pi, s->shapes[s->shape_of[j]].handle, pj, LOCD_ROUTE_AUTO,
                       LOCD_CONTACT_EPA, &hit, NULL);
    return hit;
}

static int run_ladder(locd_world *w, const sim_scene *s, const locd_pipeline_options *base, locd_contacts *c,
                      ladder_totals *t, FILE *line)
{
    int rung;
    if (line)
        fputs("\"ladder\":{", line);
    for (rung = 0; rung < LADDER_RUNGS; rung++) {
        locd_pipeline_options o;
        locd_pipeline_stats ps;
        size_t k, m, late = 0, missed = 0;
        double best = INFINITY;
        int rep;
        ladder_options(base, rung, &o);
        /* Best of 3: these calls take micro- to milliseconds on a shared machine. */
        for (rep = 0; rep < 3; rep++) {
            locd_pipeline_stats_init(&ps);
            if (locd_world_collide(w, &o, c, &ps) != LOCD_OK) {
                fprintf(stderr, "locd: ladder: %s\n", locd_last_error());
                return -1;
            }
            best = fmin(best, ps.ms_total);
        }
        ps.ms_total = best;
        m = locd_contacts_count(c);
        if (rung == 3)
            for (k = 0; k < m; k++)
                if (locd_contacts_toi(c)[k] > 0.0) {
                    if (overlap_at_end(s, locd_contacts_pairs(c)[2 * k], locd_contacts_pairs(c)[2 * k + 1]))
                        late++;
                    else
                        missed++;
                }
        t->pairs[rung] += m;
        t->ms[rung] += ps.ms_total;
        t->swept_late += late;
        t->swept_missed += missed;
        if (line) {
            fprintf(line, "%s\"%s\":{\"pairs\":%zu,\"ms\":%.4f", rung ? "," : "", ladder_names[rung], m, ps.ms_total);
            if (rung == 3)
                fprintf(line, ",\"late\":%zu,\"missed_by_discrete\":%zu", late, missed);
            fputc('}', line);
        }
    }
    if (line)
        fputs("},", line);
    return 0;
}

static void print_ladder_totals(const ladder_totals *t)
{
    int rung;
    fputs(",\"ladder\":{", stdout);
    for (rung = 0; rung < LADDER_RUNGS; rung++)
        printf("%s\"%s\":{\"pairs\":%llu,\"ms\":%.3f}", rung ? "," : "", ladder_names[rung],
               (unsigned long long)t->pairs[rung], t->ms[rung]);
    printf(",\"swept_late\":%llu,\"missed_by_discrete\":%llu}", (unsigned long long)t->swept_late,
           (unsigned long long)t->swept_missed);
}

/* ---- the run ---- */

static int setup_world(sim_scene *s, long threads, locd_world **w)
{
    locd_engine_config cfg;
    size_t i;
    locd_status st;
    locd_engine_config_init(&cfg);
    cfg.threads = threads >= 0 ? (uint32_t)threads : s->threads;
    if ((st = locd_world_create(&cfg, w)) != LOCD_OK) {
        fprintf(stderr, "locd: %s\n", locd_last_error());
        return -1;
    }
    for (i = 0; i < s->n; i++) {
        if ((st = locd_world_add(*w, s->shapes[s->shape_of[i]].handle, s->poses + 7 * i, s->vel + 6 * i, NULL)) !=
            LOCD_OK) {
            fprintf(stderr, "locd: object %zu: %s\n", i, locd_last_error());
            return -1;
        }
        /* Filters the scene asks for (the world's broad phase never pairs filtered objects). */
        if (s->has_filters && (st = locd_world_set_filter(*w, (uint32_t)i, s->category[i], s->mask[i],
                                                          s->group[i])) != LOCD_OK) {
            fprintf(stderr, "locd: object %zu: %s\n", i, locd_last_error());
            return -1;
        }
    }
    return 0;
}

static void print_summary(const sim_scene *s, const sim_state *st, const locd_pipeline_options *o, int steps,
                          const locd_pipeline_stats *total, double ms_wall, const ladder_totals *ladder,
                          const uint64_t *events)
{
    size_t i;
    int first = 1;
    printf("{\"summary\":{\"scene\":");
    json_write_string(stdout, s->name);
    printf(",\"steps\":%d,\"objects\":%zu,\"continuous\":\"%s\",\"shape_tests\":%s,"
           "\"contacts\":%s,\"response\":%s,",
           steps, s->n, swept_name(o->swept), (o->stages & LOCD_STAGE_SHAPE) ? "true" : "false",
           (o->stages & LOCD_STAGE_CONTACT) ? "true" : "false", s->response ? "true" : "false");
    printf("\"contacts_began\":%llu,\"contacts_ended\":%llu,\"removed\":%llu,", (unsigned long long)events[0],
           (unsigned long long)events[1], (unsigned long long)events[2]);
    print_stages(stdout, total);
    if (ladder)
        print_ladder_totals(ladder);
    printf(",\"dt\":%.9g,\"ms_pipeline\":%.3f,\"ms_wall\":%.3f,\"tracked\":{", s->dt, total->ms_total, ms_wall);
    for (i = 0; i < s->n; i++) {
        const double *p = s->poses + 7 * i;
        if (!s->names[i])
            continue;
        printf("%s", first ? "" : ",");
        json_write_string(stdout, s->names[i]);
        printf(":{\"position\":[%.6g,%.6g,%.6g],\"min_z\":%.6g,\"contacts\":%u}", p[0], p[1], p[2], st->min_z[i], st->hits[i]);
        first = 0;
    }
    printf("}}}\n");
}

/* Everything one run holds. */
typedef struct sim_run {
    sim_args a;
    sim_scene s;
    sim_state st;
    locd_world *w;
    locd_contacts *c, *lc; /* the step's contacts; the ladder's own */
    locd_pipeline_options o;
    locd_pipeline_stats total;
    uint64_t began, ended, removed; /* contact events and removals over the run */
    ladder_totals ladder;
    FILE *rec; /* the recorded positions, or NULL */
    char dump_path[4096];
} sim_run;

static void alloc_state(sim_state *st, sim_scene *s)
{
    size_t i;
    st->sc = s;
    st->frac = malloc(s->n * sizeof(double) + 1);
    st->vold = malloc(3 * s->n * sizeof(double) + 1);
    st->hits = calloc(s->n + 1, sizeof(uint32_t));
    st->min_z = malloc(s->n * sizeof(double) + 1);
    if (!st->frac || !st->vold || !st->hits || !st->min_z)
        cli_die("out of memory");
    for (i = 0; i < s->n; i++) {
        st->frac[i] = 1.0;
        st->min_z[i] = s->poses[7 * i + 2];
    }
}

static void free_state(sim_state *st)
{
    free(st->frac);
    free(st->vold);
    free(st->hits);
    free(st->min_z);
}

/* The stages and effects the scene declares, --continuous overriding its own. */
static void init_options(const sim_scene *s, const sim_args *a, locd_pipeline_options *o)
{
    locd_pipeline_options_init(o);
    o->dt = s->dt;
    o->swept = a->continuous >= 0 ? a->continuous : s->continuous;
    o->swept_threshold = s->swept_threshold;
    o->stages = (s->shape_tests ? LOCD_STAGE_SHAPE : 0u) | (s->contacts ? LOCD_STAGE_CONTACT : 0u);
    o->find_flags = LOCD_FIND_SORTED; /* the response order, and so the run, is deterministic */
}

/* Opens the positions file of --frames, --gif or --dump (if any) and records
 * step 0; 0, or -1 after reporting a failure. */
static int open_recording(sim_run *r)
{
    const sim_args *a = &r->a;
    if (!a->frames && !a->gif && !a->dump)
        return 0;
    if (a->dump)
        snprintf(r->dump_path, sizeof r->dump_path, "%s", a->dump);
    else if (a->frames) {
        mkdir(a->frames, 0777);
        snprintf(r->dump_path, sizeof r->dump_path, "%s/positions.jsonl", a->frames);
    } else
        snprintf(r->dump_path, sizeof r->dump_path, "%s.positions.jsonl", a->gif);
    if (!(r->rec = fopen(r->dump_path, "w"))) {
        fprintf(stderr, "locd: cannot create %s: %s\n", r->dump_path, strerror(errno));
        return -1;
    }
    write_header(r->rec, &r->s);
    write_positions(r->rec, &r->s, 0);
    return 0;
}

static void apply_gravity(sim_scene *s)
{
    size_t i;
    for (i = 0; i < s->n; i++)
        if (s->dynamic[i]) {
            double *v = s->vel + 6 * i;
            v[0] += s->gravity[0] * s->dt;
            v[1] += s->gravity[1] * s->dt;
            v[2] += s->gravity[2] * s->dt;
        }
}

/* Gravity, then the pipeline on the step's start: the contacts in r->c, the
 * statistics in *ps. 0, or -1 after reporting a failure. */
static int collide_step(sim_run *r, int step, locd_pipeline_stats *ps)
{
    apply_gravity(&r->s);
    if (locd_world_set_velocities(r->w, r->s.vel, r->s.n) != LOCD_OK) {
        fprintf(stderr, "locd: step %d: %s\n", step, locd_last_error());
        return -1;
    }
    locd_pipeline_stats_init(ps);
    if (locd_world_collide(r->w, &r->o, r->c, ps) != LOCD_OK) {
        fprintf(stderr, "locd: step %d: %s\n", step, locd_last_error());
        return -1;
    }
    return 0;
}

/* The ladder has its own result buffer: r->c still holds the step's contacts. */
static int ladder_step(sim_run *r)
{
    if (!r->lc && locd_contacts_create(&r->lc) != LOCD_OK)
        return -1;
    return run_ladder(r->w, &r->s, &r->o, r->lc, &r->ladder, r->a.quiet ? NULL : stdout);
}

/* The response to the step's contacts and the move; the world gets the new
 * poses. 0, or -1 after reporting a failure. */
static int advance(sim_run *r, int step)
{
    size_t i;
    for (i = 0; i < r->s.n; i++)
        memcpy(r->st.vold + 3 * i, r->s.vel + 6 * i, 3 * sizeof(double));
    respond(&r->st, r->c);
    integrate(&r->st);
    if (locd_world_set_poses(r->w, r->s.poses, r->s.n) != LOCD_OK) {
        fprintf(stderr, "locd: step %d: %s (the scene blew up)\n", step, locd_last_error());
        return -1;
    }
    return 0;
}

/* Objects the scene removes at this step leave the world (and stop moving);
 * the count. */
static size_t remove_due(sim_run *r, int step)
{
    size_t i, k = 0;
    if (!r->s.has_filters)
        return 0;
    for (i = 0; i < r->s.n; i++)
        if (r->s.remove_at[i] == step) {
            if (locd_world_remove(r->w, (uint32_t)i) != LOCD_OK)
                cli_die("step %d: %s", step, locd_last_error());
            r->s.dynamic[i] = 0;
            k++;
        }
    return k;
}

/* One step and its JSON line (unless --quiet); 0, or -1 after a failure. */
static int run_step(sim_run *r, int step)
{
    locd_pipeline_stats ps;
    size_t nb = 0, ne = 0, removed = remove_due(r, step);
    if (collide_step(r, step, &ps) != 0)
        return -1;
    locd_world_contact_events(r->w, NULL, &nb, NULL, &ne);
    r->began += nb;
    r->ended += ne;
    r->removed += removed;
    if (!r->a.quiet)
        printf("{\"step\":%d,\"t\":%.6g,\"objects\":%zu,\"pairs\":%zu,\"began\":%zu,\"ended\":%zu,"
               "\"removed\":%zu,\"swept_objects\":%u,",
               step, step * r->s.dt, (size_t)ps.objects, locd_contacts_count(r->c), nb, ne, removed,
               ps.swept_objects);
    if (r->a.ladder && ladder_step(r) != 0)
        return -1;
    if (advance(r, step) != 0)
        return -1;
    accumulate(&r->total, &ps);
    if (!r->a.quiet) {
        print_stages(stdout, &ps);
        printf(",\"ms_total\":%.4f}\n", ps.ms_total);
    }
    if (r->rec && step % r->a.every == 0)
        write_positions(r->rec, &r->s, step);
    return 0;
}

/* Closes the positions file and renders the frames or GIF from it; 0, or 1
 * when rendering failed. */
static int finish_recording(sim_run *r)
{
    int failed;
    if (!r->rec)
        return 0;
    /* A full disk (or /dev/full) shows only here: the writes were buffered. */
    failed = ferror(r->rec) != 0;
    failed |= fclose(r->rec) != 0;
    r->rec = NULL;
    if (failed) {
        fprintf(stderr, "locd: cannot write %s: %s\n", r->dump_path, strerror(errno ? errno : EIO));
        return 1;
    }
    if ((r->a.frames || r->a.gif) && render(r->dump_path, &r->a) != 0)
        return 1;
    return 0;
}

/* Every step, then the summary line and the rendering; 0, or 1 after a failure. */
static int run_steps(sim_run *r, int steps)
{
    double t_start;
    int step;
    locd_pipeline_stats_init(&r->total);
    t_start = cli_now_ms();
    for (step = 1; step <= steps; step++) {
        if (steps >= 10 && step % 10 == 0)
            cli_progress("simulate: step", (size_t)step, (size_t)steps + 1);
        if (run_step(r, step) != 0)
            return 1;
    }
    cli_progress("simulate: step", 1, 1);
    {
        uint64_t events[3] = {r->began, r->ended, r->removed};
        print_summary(&r->s, &r->st, &r->o, steps, &r->total, cli_now_ms() - t_start,
                      r->a.ladder ? &r->ladder : NULL, events);
    }
    return finish_recording(r);
}

static void close_run(sim_run *r)
{
    if (r->rec)
        fclose(r->rec);
    locd_contacts_destroy(r->c);
    locd_contacts_destroy(r->lc);
    locd_world_destroy(r->w);
    sim_scene_free(&r->s);
    free_state(&r->st);
}

int cmd_simulate(int argc, char **argv)
{
    sim_run r;
    char err[512];
    int steps, rc = 1;
    memset(&r, 0, sizeof r);
    if (parse_args(argc, argv, &r.a) != 0)
        return 2;
    if (sim_scene_load(r.a.scene, &r.s, err, sizeof err) != 0) {
        fprintf(stderr, "locd: %s\n", err);
        return 2;
    }
    steps = r.a.steps >= 0 ? r.a.steps : r.s.steps;
    if (r.a.dt > 0.0)
        r.s.dt = r.a.dt;
    alloc_state(&r.st, &r.s);
    if (setup_world(&r.s, r.a.threads, &r.w) == 0 && locd_contacts_create(&r.c) == LOCD_OK) {
        init_options(&r.s, &r.a, &r.o);
        if (open_recording(&r) == 0)
            rc = run_steps(&r, steps);
    }
    close_run(&r);
    return rc;
}
