/* locd: the command-line tool. One subcommand per file (cmd_*.c). */
#include "cli.h"

#include <stdio.h>
#include <string.h>

typedef struct command {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *usage;
} command;

static const command commands[] = {
    {"gen", cmd_gen, "gen KIND N [--seed S] [--pairs-per-box X] -o FILE.aabb    make a scene (kinds: uniform, clustered, mixed, lattice, far, boxprune)"},
    {"pairs", cmd_pairs, "pairs SCENE [--against B] [--threads K] [--out PAIRS.bin|-] ...   find all overlapping pairs (.aabb, .aabb64, .npy, -)"},
    {"bench", cmd_bench, "bench [--sizes 1e6,2e6] [--repeat R] [--threads-max P]   the paper's Tables 1-2 on this machine"},
    {"serve", cmd_serve, "serve --listen unix:PATH|tcp:HOST:PORT   run the level-3 service"},
    {"frames", cmd_frames, "frames SCENE.aabb --moving P --frames F [--static S] [--check]   frame-to-frame updates vs rebuild"},
    {"simulate", cmd_simulate, "simulate SCENE.json|- --steps N   run a scene through the filter pipeline"},
    {"accuracy", cmd_accuracy, "accuracy [--out accuracy.md]   what accuracy costs in time"},
};

static void usage(FILE *f)
{
    size_t i;
    fprintf(f, "locd %s: exact all-pairs collision detection on a linear octree\n\nusage:\n", locd_version_string());
    for (i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(f, "  locd %s\n", commands[i].usage);
    fprintf(f, "\n'locd COMMAND --help' describes a command's options.\n");
}

int main(int argc, char **argv)
{
    size_t i;
    if (argc < 2 || !strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? 2 : 0;
    }
    if (!strcmp(argv[1], "--version")) {
        printf("locd %s\n", locd_version_string());
        return 0;
    }
    for (i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (!strcmp(argv[1], commands[i].name))
            return commands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "locd: unknown command '%s'\n\n", argv[1]);
    usage(stderr);
    return 2;
}
