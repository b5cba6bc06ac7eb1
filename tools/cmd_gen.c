/* locd gen KIND N [--seed S] [--pairs-per-box X] -o FILE.aabb */
#include "cli.h"
#include "json.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int cmd_gen(int argc, char **argv)
{
    const char *kind = NULL, *out = NULL;
    size_t n = 0;
    uint64_t seed = 1;
    double ppb = 0.0;
    int i, have_n = 0;
    float *b;
    for (i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help")) {
            printf("usage: locd gen KIND N [--seed S] [--pairs-per-box X] -o FILE.aabb\n"
                   "kinds: %s\n"
                   "  uniform    equal cubes in the unit cube, about one overlapping pair per cube (the paper's)\n"
                   "  clustered  half the cubes in 64 dense Gaussian hot spots\n"
                   "  mixed      edges spread over three orders of magnitude, random aspect\n"
                   "  lattice    unit cubes on an integer grid: every neighbour touches\n"
                   "  far        the uniform scene scaled by 1000 and moved 1e5 from the origin\n"
                   "  boxprune   Terdiman's box-pruning scene: integer centres in [-2048, 2047]^3,\n"
                   "             half-extents 0..127 (use N = 100000 for his figures)\n"
                   "--pairs-per-box X  scale the boxes of uniform, clustered or mixed for about X\n"
                   "                   overlapping pairs per box (natural: 1, 0.53, 0.53)\n",
                   cli_generator_kinds());
            return 0;
        } else if (!strcmp(argv[i], "--seed") && i + 1 < argc) {
            seed = cli_seed_option(argv[++i], "gen");
        } else if (!strcmp(argv[i], "--pairs-per-box") && i + 1 < argc) {
            char *end;
            ppb = strtod(argv[++i], &end);
            if (*end || end == argv[i] || !(ppb > 0.0 && ppb <= 1e6))
                cli_die("gen: bad --pairs-per-box '%s' (a number > 0)", argv[i]);
        } else if ((!strcmp(argv[i], "-o") || !strcmp(argv[i], "--out")) && i + 1 < argc) {
            out = argv[++i];
        } else if (!kind) {
            kind = argv[i];
        } else if (!have_n) {
            n = cli_size_option(argv[i], 0, SIZE_MAX, "gen: bad N '%s'", argv[i]);
            have_n = 1;
        } else {
            cli_die("gen: unexpected argument '%s' (see locd gen --help)", argv[i]);
        }
    }
    if (!kind || !have_n || !out)
        cli_die("usage: locd gen KIND N [--seed S] -o FILE.aabb");
    if (!cli_generator_known(kind))
        cli_die("gen: unknown kind '%s' (kinds: %s)", kind, cli_generator_kinds());
    if (ppb > 0.0 && !cli_generator_scalable(kind))
        cli_die("gen: --pairs-per-box applies to uniform, clustered and mixed, not '%s'", kind);
    b = cli_generate_ppb(kind, n, seed, ppb);
    if (!b)
        cli_die("gen: %s (%zu boxes)", locd_status_string(LOCD_ERR_NO_MEMORY), n);
    if (cli_write_file(out, b, n * 6 * sizeof(float)) != 0) {
        free(b);
        return 1;
    }
    free(b);
    printf("{\"kind\":");
    json_write_string(stdout, kind);
    printf(",\"n\":%zu,\"seed\":%llu,", n, (unsigned long long)seed);
    if (ppb > 0.0)
        printf("\"pairs_per_box\":%g,", ppb);
    printf("\"out\":");
    json_write_string(stdout, out);
    printf("}\n");
    return 0;
}
