/* Helpers of the integration-level tests: real processes (the service, the
 * workers), /proc and /dev/shm inspection. */
#ifndef LOCD_TEST_LEVELS_UTIL_H
#define LOCD_TEST_LEVELS_UTIL_H

#include <locd/locd.h>
#include <stddef.h>
#include <sys/types.h>

/* Points LOCD_WORKER at the build's locd-worker; returns the locd CLI path. */
const char *lu_setup(void);

/* A private (0700) temporary directory, removed by lu_cleanup_dir. */
void lu_temp_dir(char *out, size_t len);
void lu_cleanup_dir(const char *dir);

/* Starts `locd serve --listen ADDR [--secret S] [--threads K]`, its stderr
 * into log_path, and waits until it says where it listens (the address is
 * copied into actual, which may differ for tcp port 0). Returns the pid. */
pid_t lu_start_service(const char *listen, const char *secret, unsigned threads, const char *log_path,
                       char *actual, size_t actual_len);
/* SIGTERM (graceful) or SIGKILL, then reap. Returns the wait status. */
int lu_stop_service(pid_t pid, int sig);

/* The suites' shared fixture: a private directory holding a 2-thread
 * service on a Unix socket (address in addr, its log in log). */
typedef struct lu_fixture {
    char dir[256], addr[300], log[300];
    pid_t service;
} lu_fixture;
/* lu_setup, then the directory and the service; 0 when the service runs. */
int lu_fixture_up(lu_fixture *f);
void lu_fixture_down(lu_fixture *f);

/* Processes whose parent is this process (0 when none). */
int lu_count_children(void);
/* pids of the children named `comm` (e.g. "locd-worker"); returns the count. */
int lu_children_named(const char *comm, pid_t *pids, int max);
/* Open file descriptors of this process. */
int lu_count_fds(void);
/* /dev/shm entries whose name starts with prefix. */
int lu_count_shm(const char *prefix);
/* Processes anywhere whose command line contains all of a and b. */
int lu_count_processes_with(const char *a, const char *b);

/* 1 when the file contains the text (now, or within timeout_ms). */
int lu_file_contains(const char *path, const char *text);
int lu_wait_file_contains(const char *path, const char *text, int timeout_ms);

/* Per-test setup/teardown (LT_TEST_FIXTURE) that print the test's wall time. */
void lu_timer_start(void);
void lu_timer_print(void);

/* Exactly equal pair lists (same pairs, same order). */
int lu_same_pairs(const locd_pairs *a, const locd_pairs *b);

/* 0 when LOCD_TEST_HEAVY=0 (sanitizer builds): shrink loops and scenes. */
int lu_heavy(void);

double lu_now_ms(void);
void lu_sleep_ms(int ms);

#endif
