/* The scene's update against a from-scratch find on the same boxes:
 *   bench_scene SCENE.aabb [--moving P] [--static S] [--frames F] [--threads T]
 * [--find 0] (updates only, for a profile).
 * Puts the scene's boxes in a locd scene (the first fraction S static),
 * then for F frames moves a random fraction P of the other objects by a
 * small step (a tenth of their size) and updates (pairs and events); prints
 * one JSON line with the medians of update and of locd_engine_find_pairs_f32
 * on the same boxes, and the medians of the process's CPU time (every
 * thread) over each (steadier than the wall clock on a shared machine).
 * docs/scene.md quotes its figures. */
#include <locd/scene.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_d);
    return v[n / 2];
}

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* CPU time of the whole process (every thread): on a shared machine it
 * varies less than the wall clock, so it compares two versions better. */
static double cpu_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static uint64_t rng(uint64_t *s)
{
    *s ^= *s << 13, *s ^= *s >> 7, *s ^= *s << 17;
    return *s;
}

int main(int argc, char **argv)
{
    double moving = 0.01, stat = 0.0, *upd, *reb, *ucpu, *rcpu;
    int frames = 10, f, i, find = 1;
    uint32_t threads = 2;
    FILE *fp;
    long size;
    size_t n, k, nstat, nmove;
    float *boxes;
    locd_engine_config cfg;
    locd_engine *e;
    locd_scene *s;
    locd_scene_add_options o;
    locd_id *ids, *mids;
    float *mbox;
    locd_pairs *pairs;
    locd_scene_stats st;
    uint64_t seed = 88172645463325252ull;
    if (argc < 2) {
        fprintf(stderr, "usage: bench_scene SCENE.aabb [--moving P] [--static S] [--frames F] [--threads T]\n");
        return 2;
    }
    for (i = 2; i + 1 < argc; i += 2) {
        if (!strcmp(argv[i], "--moving"))
            moving = atof(argv[i + 1]);
        else if (!strcmp(argv[i], "--static"))
            stat = atof(argv[i + 1]);
        else if (!strcmp(argv[i], "--frames"))
            frames = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--threads"))
            threads = (uint32_t)atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--find")) /* 0: updates only (for a profile of the update) */
            find = atoi(argv[i + 1]);
    }
    fp = fopen(argv[1], "rb");
    if (!fp || fseek(fp, 0, SEEK_END) || (size = ftell(fp)) < 0 || fseek(fp, 0, SEEK_SET)) {
        perror(argv[1]);
        return 1;
    }
    n = (size_t)size / 24;
    boxes = malloc(n * 24 + 1);
    if (fread(boxes, 24, n, fp) != n)
        return 1;
    fclose(fp);
    locd_engine_config_init(&cfg);
    cfg.threads = threads;
    if (locd_engine_create(&cfg, &e) || locd_scene_create(e, NULL, &s) || locd_pairs_create(NULL, &pairs))
        return 1;
    ids = malloc(n * sizeof *ids);
    nstat = (size_t)(stat * (double)n);
    locd_scene_add_options_init(&o);
    o.flags = LOCD_OBJECT_STATIC;
    if (locd_scene_add_f32(s, boxes, nstat, &o, ids))
        return 1;
    if (locd_scene_add_f32(s, boxes + 6 * nstat, n - nstat, NULL, ids + nstat))
        return 1;
    if (locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS))
        return 1;
    nmove = (size_t)(moving * (double)(n - nstat));
    mids = malloc((nmove + 1) * sizeof *mids);
    mbox = malloc((nmove + 1) * 24);
    upd = malloc((size_t)frames * sizeof *upd);
    reb = malloc((size_t)frames * sizeof *reb);
    ucpu = malloc((size_t)frames * sizeof *ucpu);
    rcpu = malloc((size_t)frames * sizeof *rcpu);
    locd_scene_stats_init(&st);
    for (f = 0; f < frames; f++) {
        double t, c;
        /* a random subset (distinct: a stride walk from a random start) */
        size_t start = rng(&seed) % (n - nstat), stride = 1 + (n - nstat) / (nmove ? nmove : 1);
        /* when the walk would wrap, a prefix (the objects moved are those given to the scene) */
        const int wraps = stride * nmove > (n - nstat) + stride;
        for (k = 0; k < nmove; k++) {
            size_t j = nstat + (wraps ? k : (start + k * stride) % (n - nstat));
            float *b = boxes + 6 * j, d[3];
            int a;
            for (a = 0; a < 3; a++)
                d[a] = (b[a + 3] - b[a]) * 0.1f * ((float)(rng(&seed) % 2001) / 1000.0f - 1.0f);
            for (a = 0; a < 6; a++)
                b[a] += d[a % 3];
            mids[k] = ids[j];
            memcpy(mbox + 6 * k, b, 24);
        }
        if (locd_scene_move_f32(s, mids, mbox, nmove))
            return 1;
        c = cpu_ms();
        if (locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS))
            return 1;
        ucpu[f] = cpu_ms() - c;
        locd_scene_get_stats(s, &st);
        upd[f] = st.ms_total;
        c = cpu_ms();
        t = now_ms();
        if (find && locd_engine_find_pairs_f32(e, boxes, n, 0, pairs))
            return 1;
        t = now_ms() - t;
        rcpu[f] = cpu_ms() - c;
        reb[f] = t;
    }
    {
        double um = median(upd, frames), rm = median(reb, frames), uc = median(ucpu, frames), rc = median(rcpu, frames);
        printf("{\"n\":%zu,\"static\":%zu,\"moving\":%zu,\"frames\":%d,\"threads\":%u,\"update_ms\":%.3f,"
               "\"rebuild_ms\":%.3f,\"ratio\":%.4f,\"update_cpu_ms\":%.3f,\"rebuild_cpu_ms\":%.3f,\"cpu_ratio\":%.4f,\"pairs\":%llu,\"created\":%llu,\"lost\":%llu,\"rebuilt\":%u,"
               "\"reencoded\":%llu,\"candidates\":%llu,\"entries\":%llu,\"ms_encode\":%.3f,\"ms_merge\":%.3f,\"ms_sweep\":%.3f,\"ms_events\":%.3f}\n",
               n, nstat, nmove, frames, threads, um, rm, um / rm, uc, rc, rc > 0 ? uc / rc : 0.0, (unsigned long long)st.pairs,
               (unsigned long long)st.created, (unsigned long long)st.lost, st.rebuilt,
               (unsigned long long)st.reencoded, (unsigned long long)st.candidates, (unsigned long long)st.entries, st.ms_encode, st.ms_merge, st.ms_sweep, st.ms_events);
    }
    locd_pairs_destroy(pairs);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    return 0;
}
