/* A C99 program of the narrow phase against an installed locd:
 *   cc -std=c99 -Wall -Wextra -Wpedantic -Werror narrow.c $(pkg-config --cflags --libs locd-narrow)
 * Two unit spheres 1.5 apart intersect, 2.5 apart they do not, tested by FCL. Without libccd
 * and FCL at build time the call returns LOCD_ERR_UNSUPPORTED (exit 77). */
#include <locd/pipeline.h> /* the narrow phase (liblocd_narrow); includes locd/locd.h */
#include <stdio.h>

int main(void)
{
    static const double at0[7] = {0, 0, 0, 0, 0, 0, 1};  /* x y z, quaternion x y z w */
    static const double near[7] = {1.5, 0, 0, 0, 0, 0, 1};
    static const double far[7] = {2.5, 0, 0, 0, 0, 0, 1};
    locd_shape *ball = NULL;
    int32_t hit_near = -1, hit_far = -1;
    locd_status st;

    if (locd_shape_sphere(1.0, &ball) != LOCD_OK) {
        fprintf(stderr, "locd: %s\n", locd_last_error());
        return 1;
    }
    st = locd_shape_collide(ball, at0, ball, near, LOCD_ROUTE_FCL, LOCD_CONTACT_EPA, &hit_near, NULL);
    if (st == LOCD_ERR_UNSUPPORTED) {
        printf("narrow consumer: built without the narrow phase (%s)\n", locd_last_error());
        locd_shape_destroy(ball);
        return 77;
    }
    if (st == LOCD_OK)
        st = locd_shape_collide(ball, at0, ball, far, LOCD_ROUTE_FCL, LOCD_CONTACT_EPA, &hit_far, NULL);
    locd_shape_destroy(ball);
    if (st != LOCD_OK) {
        fprintf(stderr, "locd: %s\n", locd_last_error());
        return 1;
    }
    printf("narrow consumer: near %d, far %d: %s\n", (int)hit_near, (int)hit_far,
           hit_near == 1 && hit_far == 0 ? "ok" : "WRONG");
    return hit_near == 1 && hit_far == 0 ? 0 : 1;
}
