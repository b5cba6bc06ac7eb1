/* World and contacts handles (private). */
#ifndef LOCD_NARROW_WORLD_H
#define LOCD_NARROW_WORLD_H

#include "narrow.h"

struct locd_world {
    uint32_t magic;
    locd_engine *engine;
    locd_pairs *pairs;
    locd_shape **shapes;
    double *poses; /* 7 per object */
    double *vel;   /* 6 per object */
    size_t n, cap;
    /* scratch of the last collide, sized to scratch_n objects */
    double *R;      /* 12 per object: rotation then translation */
    double *boxes;  /* 6 per object */
    uint8_t *fast;  /* 1 = swept */
    uint32_t *work; /* pair indices split by stage */
    size_t scratch_n, work_cap;
};

struct locd_contacts {
    uint32_t magic;
    int has_contact;
    size_t count, cap;
    uint32_t *pairs;
    double *toi, *depth, *normal, *point;
};

locd_status lc_world_check(const locd_world *w);
locd_status lc_contacts_check(const locd_contacts *c);
locd_status lc_contacts_reserve(locd_contacts *c, size_t count);

#endif
