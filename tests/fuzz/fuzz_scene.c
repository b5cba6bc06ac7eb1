/* libFuzzer harness: the JSON scene reader of `locd simulate`
 * (tools/json.c, tools/sim_scene.c; format in docs/pipeline.md). Each
 * input is a scene file: sim_scene_load reads it from a memory file
 * (memfd, so through the same fopen/fread path as a scene on disk), builds
 * its shapes (convex hulls, meshes, rocks, terrain) and objects, and frees
 * everything. The JSON parser alone also sees the input, as text cut at
 * its first NUL, for the parts of the tree no scene field reaches.
 * Seeds: tests/fuzz/corpus/scene/ (the scenes of examples/ and edge cases). */
#define _GNU_SOURCE
#include "json.h"
#include "sim_scene.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

static int g_fd = -1;
static char g_path[64];
static int g_verbose; /* LOCD_FUZZ_VERBOSE=1: what the reader made of each input */

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    g_verbose = getenv("LOCD_FUZZ_VERBOSE") != NULL;
    g_fd = memfd_create("locd-fuzz-scene", MFD_CLOEXEC);
    if (g_fd < 0) {
        fprintf(stderr, "fuzz_scene: memfd_create: %s\n", strerror(errno));
        abort();
    }
    snprintf(g_path, sizeof g_path, "/proc/self/fd/%d", g_fd);
    return 0;
}

static void parse_text(const uint8_t *data, size_t size)
{
    char err[256];
    char *text = malloc(size + 1);
    json_value *v;
    if (!text)
        return;
    memcpy(text, data, size);
    text[size] = '\0';
    v = json_parse(text, err, sizeof err);
    if (v) {
        double d[3];
        const char *s;
        int b;
        /* The typed look-ups on whatever the root is. */
        json_get_number(v, "dt", d);
        json_get_bool(v, "contacts", &b);
        json_get_string(v, "name", &s);
        json_get_vec(v, "gravity", d, 3);
        json_free(v);
    } else {
        volatile size_t n = strlen(err);
        (void)n;
    }
    free(text);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    sim_scene s;
    char err[512];
    if (ftruncate(g_fd, 0) != 0 || pwrite(g_fd, data, size, 0) != (ssize_t)size)
        abort();
    if (sim_scene_load(g_path, &s, err, sizeof err) == 0) {
        if (g_verbose)
            fprintf(stderr, "  scene: %zu objects, %zu shapes\n", s.n, s.nshapes);
        sim_scene_free(&s);
    } else {
        volatile size_t n = strlen(err);
        (void)n;
        if (g_verbose)
            fprintf(stderr, "  refused: %s\n", err);
    }
    parse_text(data, size);
    return 0;
}
