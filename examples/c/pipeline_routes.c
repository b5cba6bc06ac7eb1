/* The pipeline from C, and what each route costs: builds a world with a
 * floor and a fast ball, catches the ball with the swept stage, then times
 * one pair test through each route (closed form, libccd, FCL) on random
 * poses of sphere-sphere and box-box pairs.
 *
 *   build/examples/pipeline_routes [pairs]      (default 200; docs/pipeline.md uses 5000)
 */
#include <locd/locd.h>
#include <locd/pipeline.h>

#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

static double uniform(unsigned long long *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*s >> 11) * (1.0 / 9007199254740992.0);
}

static int fast_ball(void)
{
    locd_shape *floor_, *ball;
    locd_world *w;
    locd_contacts *c;
    locd_pipeline_options o;
    locd_pipeline_stats s;
    double pf[7] = {0, 0, -0.1, 0, 0, 0, 1}, pb[7] = {0, 0, 1, 0, 0, 0, 1}, vb[6] = {0, 0, -300, 0, 0, 0};
    int mode;
    if (locd_shape_box(10, 10, 0.1, &floor_) != LOCD_OK || locd_shape_sphere(0.25, &ball) != LOCD_OK ||
        locd_world_create(NULL, &w) != LOCD_OK || locd_contacts_create(&c) != LOCD_OK) {
        fprintf(stderr, "pipeline_routes: %s\n", locd_last_error());
        return 1;
    }
    locd_world_add(w, floor_, pf, NULL, NULL);
    locd_world_add(w, ball, pb, vb, NULL);
    locd_shape_destroy(floor_); /* the world keeps its shapes */
    locd_shape_destroy(ball);
    for (mode = LOCD_SWEPT_OFF; mode <= LOCD_SWEPT_AUTO; mode++) {
        locd_pipeline_options_init(&o);
        o.stages = LOCD_STAGE_SHAPE | LOCD_STAGE_CONTACT;
        o.swept = mode;
        o.dt = 1.0 / 60.0;
        locd_pipeline_stats_init(&s);
        locd_world_collide(w, &o, c, &s);
        printf("swept %-4s: %zu contact(s)", mode == 0 ? "off" : mode == 1 ? "on" : "auto", locd_contacts_count(c));
        if (locd_contacts_count(c))
            printf(", time of impact %.6f of the step, normal z %.3f", locd_contacts_toi(c)[0],
                   locd_contacts_normal(c)[2]);
        printf("  [swept stage: %llu call(s)]\n", (unsigned long long)s.swept.calls);
    }
    locd_contacts_destroy(c);
    locd_world_destroy(w);
    return 0;
}

static void time_routes(const char *what, locd_shape *a, locd_shape *b, size_t n)
{
    static const char *const names[] = {"closed", "libccd", "FCL"};
    static const int32_t routes[] = {LOCD_ROUTE_CLOSED, LOCD_ROUTE_CCD, LOCD_ROUTE_FCL};
    double *poses = malloc(14 * n * sizeof(double));
    unsigned long long seed = 12345;
    size_t i;
    int r, contact;
    if (!poses)
        return;
    for (i = 0; i < 2 * n; i++) {
        double *p = poses + 7 * i;
        int k;
        for (k = 0; k < 3; k++)
            p[k] = 1.2 * uniform(&seed);
        for (k = 3; k < 7; k++)
            p[k] = uniform(&seed) - 0.5;
    }
    for (i = 0; i < n; i++) { /* warm-up: caches and clocks */
        int32_t hit;
        locd_shape_collide(a, poses + 14 * i, b, poses + 14 * i + 7, LOCD_ROUTE_CLOSED, LOCD_CONTACT_EPA, &hit, NULL);
    }
    for (contact = 0; contact < 2; contact++)
        for (r = 0; r < 3; r++) {
            double best = 1e300, cbuf[7];
            size_t hits = 0;
            int rep;
            for (rep = 0; rep < 3; rep++) { /* best of 3: the machine may be shared */
                double t0 = now_ms();
                hits = 0;
                for (i = 0; i < n; i++) {
                    int32_t hit = 0;
                    locd_shape_collide(a, poses + 14 * i, b, poses + 14 * i + 7, routes[r], LOCD_CONTACT_EPA, &hit,
                                       contact ? cbuf : NULL);
                    hits += (size_t)hit;
                }
                if (now_ms() - t0 < best)
                    best = now_ms() - t0;
            }
            printf("%-13s %-7s %-8s %8.3f us/pair  (%zu of %zu pairs collide)\n", what, names[r],
                   contact ? "contact" : "yes/no", best * 1e3 / (double)n, hits, n);
        }
    free(poses);
}

int main(int argc, char **argv)
{
    size_t n = argc > 1 ? (size_t)strtoull(argv[1], NULL, 10) : 200; /* small: CI runs it under valgrind */
    locd_shape *s1, *s2, *b1, *b2;
    if (fast_ball() != 0)
        return 1;
    if (locd_shape_sphere(0.5, &s1) != LOCD_OK || locd_shape_sphere(0.4, &s2) != LOCD_OK ||
        locd_shape_box(0.5, 0.3, 0.4, &b1) != LOCD_OK || locd_shape_box(0.4, 0.4, 0.2, &b2) != LOCD_OK)
        return 1;
    time_routes("sphere-sphere", s1, s2, n);
    time_routes("box-box", b1, b2, n);
    locd_shape_destroy(s1);
    locd_shape_destroy(s2);
    locd_shape_destroy(b1);
    locd_shape_destroy(b2);
    return 0;
}
