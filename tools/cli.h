/* Shared helpers of the locd command-line tool. */
#ifndef LOCD_CLI_H
#define LOCD_CLI_H

#include <locd/locd.h>
#include <stddef.h>
#include <stdint.h>

/* A scene as loaded from .aabb (float32), .aabb64 (float64) or .npy
 * (float32 or float64, shape (n, 6), C order, little-endian); docs/formats.md. */
typedef struct cli_scene {
    size_t n;
    int f64;
    float *f;  /* 6n values when !f64 */
    double *d; /* 6n values when f64 */
} cli_scene;

/* path "-" reads stdin: .npy when it starts with the NumPy magic, else
 * .aabb (float32). 0, or -1 after a message on stderr. */
int cli_load_scene(const char *path, cli_scene *s);
void cli_free_scene(cli_scene *s);
/* Writes m pairs (2m uint32, little-endian) to path ("-": stdout); 0 on success. */
int cli_write_pairs(const char *path, const uint32_t *pairs, size_t m);
int cli_write_file(const char *path, const void *data, size_t bytes);

/* Deterministic generator (splitmix64 seeded xoshiro256**). */
typedef struct cli_rng {
    uint64_t s[4];
} cli_rng;
void cli_rng_seed(cli_rng *r, uint64_t seed);
uint64_t cli_rng_next(cli_rng *r);
double cli_rng_uniform(cli_rng *r); /* [0, 1) */
double cli_rng_normal(cli_rng *r);

/* Scene generators: kinds "uniform", "clustered", "mixed", "lattice", "far",
 * "boxprune". Returns 6n floats (malloc) or NULL for an unknown kind. */
float *cli_generate(const char *kind, size_t n, uint64_t seed);
/* The same with every box edge scaled for about pairs_per_box overlapping
 * pairs per box (0: the kind's natural size); only for the kinds
 * cli_generator_scalable accepts (uniform, clustered, mixed). */
float *cli_generate_ppb(const char *kind, size_t n, uint64_t seed, double pairs_per_box);
int cli_generator_scalable(const char *kind);
/* 1 if cli_generate knows the kind (so a NULL from it means out of memory). */
int cli_generator_known(const char *kind);
const char *cli_generator_kinds(void);

/* Progress of a long command, "\rlocd: what done/total" on stderr, only when
 * stderr is a terminal (never in a pipe, a log or CI); done == total
 * clears the line. */
int cli_stderr_is_terminal(void);
void cli_progress(const char *what, size_t done, size_t total);

void cli_cpu_model(char *buf, size_t len);
double cli_median(double *v, size_t n);
/* The mean of v[0, n) (0 when n is 0): with the median, what a run of
 * frames costs when some cost more than most. */
double cli_mean(const double *v, size_t n);
double cli_now_ms(void);
void cli_sleep_ms(double ms); /* the calling thread sleeps ms milliseconds */
void cli_die(const char *fmt, ...);
int cli_parse_size(const char *s, size_t *out); /* accepts 1e6, 1000000, 1M, 10k */
/* A size option's value s (as cli_parse_size reads it) when it lies in
 * lo..hi; otherwise exits with the message fmt, like cli_die. */
size_t cli_size_option(const char *s, size_t lo, size_t hi, const char *fmt, ...);
/* A seed: a whole decimal number 0..2^64-1 and nothing else (strtoull
 * alone reads "junk" as 0 and "-1" as 2^64-1); otherwise exits naming opt. */
uint64_t cli_seed_option(const char *s, const char *cmd);

/* The shared secret of a level-3 service, from --secret-file (file),
 * --secret (arg, which is overwritten in argv after a warning) or the
 * LOCD_SECRET environment variable, in that order; NULL when none is
 * given. malloc'd; exits on a bad file. cmd names the subcommand. */
char *cli_secret(const char *cmd, char *arg, const char *file);
/* `locd serve` refuses shorter secrets (a guessable secret is no secret). */
#define CLI_MIN_SECRET 16

/* Subcommands. argv[0] is the subcommand name. */
int cmd_gen(int argc, char **argv);
int cmd_pairs(int argc, char **argv);
int cmd_bench(int argc, char **argv);
int cmd_serve(int argc, char **argv);
int cmd_simulate(int argc, char **argv);
int cmd_frames(int argc, char **argv);
int cmd_accuracy(int argc, char **argv);

#endif
