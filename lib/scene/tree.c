/* The broad phase's entry lists (filled in by the incremental update). */
#include "scene/scene.h"

void lc_scene_tree_fini(locd_scene *s)
{
    lc_buf_release(s->alloc, &s->dyn.ent, sizeof(uint64_t));
    lc_buf_release(s->alloc, &s->sta.ent, sizeof(uint64_t));
    s->dyn.count = s->sta.count = 0;
}
