/* The frame-to-frame workload of `locd frames` and bench/frames_peers: which
 * objects are static (a fraction of the scene, chosen by seed), and, each
 * frame, which of the others move and by how much. The same seed gives the
 * same frames everywhere, so the locd scene and its peers see equal work. */
#ifndef LOCD_TOOLS_FRAMES_MOTION_H
#define LOCD_TOOLS_FRAMES_MOTION_H

#include "cli.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct frames_motion {
    size_t n;
    uint8_t *is_static; /* n flags */
    uint32_t *dynamic;  /* the non-static indices; each frame's movers are its first `moved` */
    uint8_t *mark;      /* n scratch flags (sorting the movers) */
    size_t ndynamic;
    size_t moved;       /* objects moved per frame: round(moving * ndynamic) */
    double step;        /* largest displacement per axis per frame */
    cli_rng rng;
} frames_motion;

/* static_frac and moving in [0, 1]. The step is 3% of the mean box edge.
 * 0, or -1 when out of memory. */
int frames_motion_init(frames_motion *m, const float *boxes, size_t n, double static_frac, double moving,
                       uint64_t seed);
/* Picks this frame's movers (m->dynamic[0 .. m->moved - 1], a uniform random
 * subset, in ascending index order: the order an engine walks its bodies in)
 * and shifts their boxes in place by a random vector in [-step, step]^3. */
void frames_motion_step(frames_motion *m, float *boxes);
void frames_motion_free(frames_motion *m);

#ifdef __cplusplus
}
#endif

#endif
