/* Batch checks (checks.c): each runs before anything is changed, so a
 * failing call leaves the scene as it was; the error names the first bad
 * position in the batch (locd_last_error_index). */
#ifndef LOCD_SCENE_CHECKS_H
#define LOCD_SCENE_CHECKS_H

#include "scene/slots.h"

/* What is wrong with one box, as doubles (a float converts exactly):
 * LOCD_ERR_NONFINITE, LOCD_ERR_INVERTED_BOX (*axis set) or LOCD_OK; no
 * error is recorded (the checks below record it, naming the position).
 * Inline: a move of every object checks a million boxes a frame. The
 * common case is one branch: every |x| <= DBL_MAX (false for NaN and
 * infinities) and every min <= max. */
LC_INLINE locd_status lc_scene_box_fault(const double *b, int *axis)
{
    int a, ok = 1;
    for (a = 0; a < 6; a++)
        ok &= fabs(b[a]) <= DBL_MAX;
    for (a = 0; a < 3; a++)
        ok &= b[a] <= b[a + 3];
    if (ok)
        return LOCD_OK;
    for (a = 0; a < 6; a++)
        if (!isfinite(b[a]))
            return LOCD_ERR_NONFINITE;
    for (a = 0; a < 3; a++)
        if (b[a] > b[a + 3]) {
            *axis = a;
            return LOCD_ERR_INVERTED_BOX;
        }
    return LOCD_OK;
}
locd_status lc_scene_check_boxes_f32(const float *boxes, size_t n);
locd_status lc_scene_check_boxes_f64(const double *boxes, size_t n);
/* Every id live and none twice (stamps only): each position in order, so
 * the error names the first bad one; with boxes (not NULL: floats or
 * doubles), each position's box too. n above the live objects is refused
 * before any read. */
locd_status lc_scene_check_batch(locd_scene *s, const locd_id *ids, const void *boxes, int f64, size_t n);
/* n ids no more than the live objects (checked before any read). */
locd_status lc_scene_check_count(const locd_scene *s, size_t n);
locd_status lc_scene_check_ids(locd_scene *s, const locd_id *ids, size_t n);
/* Every id live (duplicates allowed: for reads). */
locd_status lc_scene_check_ids_live(const locd_scene *s, const locd_id *ids, size_t n);
locd_status lc_scene_check_handle(const locd_scene *s);

#endif
