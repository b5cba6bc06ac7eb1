/* The update's path and the back-off waits. lc_path_choose is the one
 * place the path is chosen; docs/scene.md ("The paths") copies its rule.
 *
 * Measured at 10^6 uniform cubes on 2 threads: when more than 8% of the
 * objects moved and all of them search the entry lists, an incremental
 * update costs about what a from-scratch one does; with partner lists an
 * object that stays in its fat box costs a tenth of a search, so up to 25%
 * moving is cheaper incrementally (`locd frames u.aabb --moving P`). Past
 * 25%, the near-pair list serves the frames where most objects moved a
 * little. */
#include "scene/scene.h"

/* The shares of moved objects past which an update goes from scratch:
 * without partner lists, and with them (also the near-pair list's share). */
#define LC_SCRATCH_SHARE 0.08
#define LC_SCRATCH_SHARE_PARTNERS 0.25
/* Fewer moved objects than this never make an update go from scratch. */
#define LC_PATH_MIN_MOVED 64
/* A scene with no entry lists would go from scratch at every update with
 * more than 8% moved and never get the partner lists that make up to 25%
 * cheaper: of such updates in a row with at most 25% moved, the
 * LC_BAND_WAIT-th relists instead (several from-scratch updates' cost,
 * once). When the partner lists are then dropped (the objects jump), the
 * wait doubles, up to LC_BACKOFF_MAX; an update whose moved objects
 * mostly stayed in their fat boxes sets it back. */
#define LC_BAND_WAIT 2
/* A near-pair list that served no update before a box left its fat box
 * cost a build for nothing: the next LC_NEAR_WAIT updates from scratch
 * build none, twice as many after each such list, up to LC_BACKOFF_MAX. */
#define LC_NEAR_WAIT 2
/* A near-pair list amortizes its build (about two from-scratch updates)
 * over the updates it serves. Its margin is an eighth of the largest edge
 * at first; a list that served fewer than LC_NEAR_SERVE_MIN updates makes
 * the next one's twice as wide (up to a quarter), one that served more
 * than LC_NEAR_SERVE_MAX halves it (down to a sixteenth, as the entry
 * lists' fat boxes), as a wider margin costs more candidates a pass and a
 * dearer build. Objects that move a random step of up to 3% of their edge
 * a frame (`locd frames`) leave a sixteenth's margin after 2 updates and
 * an eighth's after about 4: at 100% moving the mean update is then below
 * a rebuild from 10^3 objects (`bench/frames.py`, docs/benchmarks.md). */
#define LC_NEAR_SERVE_MIN 4
#define LC_NEAR_SERVE_MAX 16
#define LC_BACKOFF_MAX 64
/* Partner lists are kept while the moved objects mostly stay in their fat
 * boxes. A survey where more of them left than stayed drops the lists when
 * at least LC_PARTNERS_MIN_LEFT left (searching every moved object costs
 * less than searching most of them and keeping the lists), or when those
 * that left are over LC_SCRATCH_SHARE of the objects: an update whose
 * moved objects all search costs more than one from scratch there, and
 * the lists are what kept it incremental (a small scene, whose updates
 * never move 1024 objects: at 10^3 cubes, 10% of them moved by a tenth of
 * their edge, the update cost 1.6-1.7 times a rebuild with them,
 * `bench_scene SCENE --moving 0.1`). */
#define LC_PARTNERS_MIN_LEFT 1024
/* Partner lists are built again (at the end of an incremental update)
 * after LC_CALM_UPDATES updates in a row in which at least LC_CALM_TENTHS
 * tenths of the moved objects stayed in their fat boxes. */
#define LC_CALM_UPDATES 4
#define LC_CALM_TENTHS 9

/* More than `share` of the live objects, and more than LC_PATH_MIN_MOVED. */
LC_INLINE int count_over(size_t count, size_t live, double share)
{
    return (double)count > share * (double)live && count > LC_PATH_MIN_MOVED;
}

LC_INLINE int moved_over(const lc_path_facts *f, double share)
{
    return count_over(f->moved, f->live, share);
}

/* Most objects moved: the near-pair list's updates. */
static int near_share(const lc_path_facts *f)
{
    return f->has_set && moved_over(f, LC_SCRATCH_SHARE_PARTNERS);
}

void lc_path_facts_of(locd_scene *s, size_t moved, lc_finding finding, lc_path_facts *f)
{
    f->moved = moved;
    f->live = s->slots.live;
    f->has_set = s->set.valid;
    f->has_entries = s->entries.valid;
    f->has_partners = s->partners.valid;
    f->near_usable = lc_near_usable(s);
    /* (only asked when it matters: it may read every slot once) */
    f->near_applies = near_share(f) && lc_near_applies(s);
    f->backoff = s->backoff;
    f->finding = finding;
}

/* No entry lists, more than 8% and at most 25% moved (LC_BAND_WAIT). */
static int in_band(const lc_path_facts *f)
{
    return f->has_set && !f->has_entries && moved_over(f, LC_SCRATCH_SHARE) &&
           !moved_over(f, LC_SCRATCH_SHARE_PARTNERS);
}

static uint32_t band_wait(const lc_backoff *b)
{
    return b->band_wait ? b->band_wait : LC_BAND_WAIT;
}

/* From scratch: building the near-pair list when most objects moved, a
 * list applies and it is not waiting. */
static int wants_near(const lc_path_facts *f)
{
    return near_share(f) && f->near_applies;
}

static lc_path from_scratch(const lc_path_facts *f)
{
    return wants_near(f) && !f->backoff.near_skip ? LC_PATH_NEAR_BUILD : LC_PATH_FROM_SCRATCH;
}

lc_path lc_path_choose(const lc_path_facts *f)
{
    if (f->finding == LC_FOUND_LEFT_NEAR)
        return from_scratch(f);
    if (f->finding == LC_FOUND_OUTSIDE)
        return LC_PATH_RELIST;
    if (!f->has_set)
        return LC_PATH_FROM_SCRATCH;
    if (f->near_usable && near_share(f))
        return LC_PATH_NEAR;
    if (in_band(f) && f->backoff.band_updates + 1 >= band_wait(&f->backoff))
        return LC_PATH_RELIST;
    if (moved_over(f, f->has_partners ? LC_SCRATCH_SHARE_PARTNERS : LC_SCRATCH_SHARE))
        return from_scratch(f);
    return f->has_entries ? LC_PATH_INCREMENTAL : LC_PATH_RELIST;
}

int lc_path_partners_go(size_t left, size_t stayed, size_t live)
{
    return left > stayed && (left >= LC_PARTNERS_MIN_LEFT || count_over(left, live, LC_SCRATCH_SHARE));
}

/* A wait doubled after a cache that did not pay for itself. */
LC_INLINE uint32_t doubled(uint32_t w)
{
    return 2 * w < LC_BACKOFF_MAX ? 2 * w : LC_BACKOFF_MAX;
}

void lc_backoff_chose(lc_backoff *b, const lc_path_facts *f, lc_path p)
{
    const int scratch = p == LC_PATH_FROM_SCRATCH || p == LC_PATH_NEAR_BUILD;
    if (p == LC_PATH_RELIST && f->finding == LC_FOUND_NOTHING && in_band(f))
        b->band_updates = 0; /* the band's relist, at last */
    if (scratch && f->finding != LC_FOUND_LEFT_NEAR)
        b->band_updates = in_band(f) ? b->band_updates + 1 : 0;
    if (scratch && wants_near(f) && b->near_skip)
        b->near_skip--;
}

void lc_backoff_near_left(lc_backoff *b, uint32_t served)
{
    if (served < LC_NEAR_SERVE_MIN && b->near_narrow > LC_NEAR_NARROW_MIN)
        b->near_narrow--;
    else if (served > LC_NEAR_SERVE_MAX && b->near_narrow < LC_NEAR_NARROW_MAX)
        b->near_narrow++;
    if (served) {
        b->near_wait = 0;
        return;
    }
    b->near_wait = b->near_wait ? doubled(b->near_wait) : LC_NEAR_WAIT;
    b->near_skip = b->near_wait;
}

void lc_backoff_partners_dropped(lc_backoff *b)
{
    b->calm_updates = 0;
    b->band_wait = doubled(band_wait(b));
}

int lc_backoff_survey(lc_backoff *b, int has_partners, size_t calm, size_t total)
{
    const int calm_now = calm * 10 >= total * LC_CALM_TENTHS;
    if (has_partners) {
        if (calm_now)
            b->band_wait = 0;
        return 0;
    }
    b->calm_updates = calm_now ? b->calm_updates + 1 : 0;
    return b->calm_updates >= LC_CALM_UPDATES;
}

void lc_backoff_partners_built(lc_backoff *b)
{
    b->calm_updates = 0;
}
