/* The move's hand-over to the next update (handover.h). */
#include "scene/scene.h"

int lc_handover_open(locd_scene *s, size_t n, uint32_t k)
{
    lc_handover *h = &s->handover;
    h->has_bounds = h->encoded = 0;
    if (!lc_kept_next_open(s, n, k) || !(h->qbox = lc_inproc_qbox(s->engine, n)))
        return 0;
    return 1;
}

int lc_handover_chunk(locd_scene *s, uint32_t t, const float *boxes, size_t first, size_t count)
{
    return lc_kept_next_encode(s, t, boxes, first, count, s->handover.qbox);
}

void lc_handover_close(locd_scene *s, const float lo[3], const float hi[3], int encoded)
{
    lc_handover *h = &s->handover;
    int a;
    h->epoch = s->slots.epoch;
    h->has_bounds = 1;
    for (a = 0; a < 3; a++)
        h->lo[a] = lo[a], h->hi[a] = hi[a];
    h->encoded = encoded;
    h->qbox_epoch = lc_inproc_qbox_epoch(s->engine);
}

int lc_handover_bounds(const locd_scene *s, float lo[3], float hi[3])
{
    const lc_handover *h = &s->handover;
    int a;
    if (!h->has_bounds || h->epoch != s->slots.epoch)
        return 0;
    for (a = 0; a < 3; a++)
        lo[a] = h->lo[a], hi[a] = h->hi[a];
    return 1;
}

int lc_handover_take_encode(locd_scene *s)
{
    lc_handover *h = &s->handover;
    const int ok = h->encoded && h->epoch == s->slots.epoch && h->qbox_epoch == lc_inproc_qbox_epoch(s->engine);
    h->encoded = 0;
    return ok;
}
