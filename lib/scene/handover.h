/* The move's hand-over (handover.c): a move of every object in slot order
 * reads every box, and hands the next update what it found on the way
 * while the boxes were in the caches: their bounds, and their encode for
 * the kept entry list. The update takes them only while nothing could
 * have changed them: the slots' epoch is the one they were made at (every
 * add, move and remove advances it), and, for the encode, nothing else
 * wrote the engine's packed boxes since (lc_inproc_qbox_epoch). */
#ifndef LOCD_SCENE_HANDOVER_H
#define LOCD_SCENE_HANDOVER_H

#include "scene/slots.h"

typedef struct lc_handover {
    uint64_t epoch;        /* the slots' epoch of the move that made it */
    int has_bounds;
    float lo[3], hi[3];    /* the bounds of every box */
    int encoded;           /* the kept entry list's next regions hold every box's entries */
    uint64_t qbox_epoch;   /* the engine's packed-box epoch after that encode */
    uint64_t *qbox;        /* the engine's packed boxes, which the encode wrote */
} lc_handover;

/* The move's side. Open: room for the encode of n boxes in k shares (0:
 * no encode this time). Chunk: share t's boxes [first, first + count) (0:
 * the encode failed: the hand-over carries none). Close: every box was
 * read, with bounds lo and hi, and encoded when `encoded`. */
int lc_handover_open(locd_scene *s, size_t n, uint32_t k);
int lc_handover_chunk(locd_scene *s, uint32_t t, const float *boxes, size_t first, size_t count);
void lc_handover_close(locd_scene *s, const float lo[3], const float hi[3], int encoded);

/* The update's side. The bounds of every box now (1), or 0. The encode
 * (1: the kept entry list's next regions are this update's), taken once. */
int lc_handover_bounds(const locd_scene *s, float lo[3], float hi[3]);
int lc_handover_take_encode(locd_scene *s);

#endif
