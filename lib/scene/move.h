/* Large moves on the pool (move.c). */
#ifndef LOCD_SCENE_MOVE_H
#define LOCD_SCENE_MOVE_H

#include "scene/slots.h"

/* A move of n objects split over the pool, when n is large and the scene
 * has threads or the batch may be every object in slot order (one thread:
 * its passes on the caller's thread): returns 1 and the status in *st,
 * else 0 (the caller moves them). */
int lc_scene_move_parallel(locd_scene *s, const locd_id *ids, const void *boxes, int f64, size_t n, locd_status *st);

#endif
