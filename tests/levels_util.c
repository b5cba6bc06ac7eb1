#include "levels_util.h"

#define _GNU_SOURCE
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#ifndef LOCD_BUILD_DIR
#define LOCD_BUILD_DIR "."
#endif

static char cli_path[4096];

const char *lu_setup(void)
{
    char worker[4096];
    const char *b = getenv("LOCD_TEST_BUILD_DIR");
    if (!b || !b[0])
        b = LOCD_BUILD_DIR;
    snprintf(worker, sizeof worker, "%s/lib/locd-worker", b);
    snprintf(cli_path, sizeof cli_path, "%s/tools/locd", b);
    setenv("LOCD_WORKER", worker, 1);
    signal(SIGPIPE, SIG_IGN);
    return cli_path;
}

void lu_temp_dir(char *out, size_t len)
{
    snprintf(out, len, "/tmp/locd-test-XXXXXX");
    if (!mkdtemp(out)) {
        perror("mkdtemp");
        abort();
    }
}

void lu_cleanup_dir(const char *dir)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    char p[4200];
    if (!d)
        return;
    while ((e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        unlink(p);
    }
    closedir(d);
    rmdir(dir);
}

double lu_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

void lu_sleep_ms(int ms)
{
    struct timespec ts;
    ts.tv_sec = ms / 1000;
    ts.tv_nsec = (long)(ms % 1000) * 1000000L;
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR)
        ;
}

int lu_file_contains(const char *path, const char *text)
{
    FILE *f = fopen(path, "rb");
    char *buf;
    long len;
    int found;
    if (!f)
        return 0;
    fseek(f, 0, SEEK_END);
    len = ftell(f);
    fseek(f, 0, SEEK_SET);
    buf = calloc(1, (size_t)len + 1);
    if (!buf || fread(buf, 1, (size_t)len, f) != (size_t)len) {
        free(buf);
        fclose(f);
        return 0;
    }
    fclose(f);
    found = strstr(buf, text) != NULL;
    free(buf);
    return found;
}

pid_t lu_start_service(const char *listen, const char *secret, unsigned threads, const char *log_path,
                       char *actual, size_t actual_len)
{
    char th[16];
    const char *argv[10];
    int a = 0;
    pid_t pid;
    double until;
    snprintf(th, sizeof th, "%u", threads ? threads : 2);
    argv[a++] = cli_path;
    argv[a++] = "serve";
    argv[a++] = "--listen";
    argv[a++] = listen;
    argv[a++] = "--threads";
    argv[a++] = th;
    if (secret) {
        argv[a++] = "--secret";
        argv[a++] = secret;
    }
    argv[a] = NULL;
    unlink(log_path); /* never read an older service's line */
    pid = fork();
    if (pid == 0) {
        int fd = open(log_path, O_WRONLY | O_CREAT | O_TRUNC, 0600), nul = open("/dev/null", O_RDWR);
        prctl(PR_SET_PDEATHSIG, SIGKILL); /* a crashed test leaves no service behind */
        if (fd >= 0) {
            dup2(fd, 2);
            close(fd);
        }
        if (nul >= 0) {
            dup2(nul, 0);
            dup2(nul, 1);
            close(nul);
        }
        execv(cli_path, (char *const *)argv);
        _exit(127);
    }
    if (pid < 0)
        return -1;
    until = lu_now_ms() + 10000.0;
    while (lu_now_ms() < until) {
        FILE *f = fopen(log_path, "r");
        char line[512];
        int status;
        if (f) {
            while (fgets(line, sizeof line, f)) {
                char *p = strstr(line, "listening on ");
                if (p) {
                    char *end;
                    p += strlen("listening on ");
                    end = strchr(p, ' ');
                    if (end)
                        *end = '\0';
                    snprintf(actual, actual_len, "%s", p);
                    fclose(f);
                    return pid;
                }
            }
            fclose(f);
        }
        if (waitpid(pid, &status, WNOHANG) == pid)
            return -1;
        lu_sleep_ms(10);
    }
    fprintf(stderr, "# service did not start in time\n");
    kill(pid, SIGKILL);
    waitpid(pid, NULL, 0);
    return -1;
}

int lu_stop_service(pid_t pid, int sig)
{
    int status = 0;
    kill(pid, sig);
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR)
        ;
    return status;
}

static int read_stat(const char *pid, char *comm, size_t clen, long *ppid)
{
    char p[300], buf[1024];
    FILE *f;
    char *l, *r;
    snprintf(p, sizeof p, "/proc/%s/stat", pid);
    f = fopen(p, "r");
    if (!f)
        return -1;
    if (!fgets(buf, sizeof buf, f)) {
        fclose(f);
        return -1;
    }
    fclose(f);
    l = strchr(buf, '(');
    r = strrchr(buf, ')');
    if (!l || !r)
        return -1;
    snprintf(comm, clen, "%.*s", (int)(r - l - 1), l + 1);
    if (sscanf(r + 2, "%*c %ld", ppid) != 1)
        return -1;
    return 0;
}

int lu_children_named(const char *comm, pid_t *pids, int max)
{
    DIR *d = opendir("/proc");
    struct dirent *e;
    int n = 0;
    long me = (long)getpid();
    if (!d)
        return 0;
    while ((e = readdir(d)) != NULL) {
        char c[64];
        long pp;
        if (e->d_name[0] < '0' || e->d_name[0] > '9')
            continue;
        if (read_stat(e->d_name, c, sizeof c, &pp) != 0 || pp != me)
            continue;
        if (comm && strcmp(c, comm) != 0)
            continue;
        if (pids && n < max)
            pids[n] = (pid_t)atol(e->d_name);
        n++;
    }
    closedir(d);
    return n;
}

int lu_count_children(void)
{
    return lu_children_named(NULL, NULL, 0);
}

int lu_count_fds(void)
{
    DIR *d = opendir("/proc/self/fd");
    struct dirent *e;
    int n = 0;
    if (!d)
        return -1;
    while ((e = readdir(d)) != NULL)
        if (e->d_name[0] != '.')
            n++;
    closedir(d);
    return n - 1; /* the directory's own fd */
}

int lu_count_shm(const char *prefix)
{
    DIR *d = opendir("/dev/shm");
    struct dirent *e;
    int n = 0;
    if (!d)
        return 0;
    while ((e = readdir(d)) != NULL)
        if (!strncmp(e->d_name, prefix, strlen(prefix)))
            n++;
    closedir(d);
    return n;
}

int lu_count_processes_with(const char *a, const char *b)
{
    DIR *d = opendir("/proc");
    struct dirent *e;
    int n = 0;
    if (!d)
        return 0;
    while ((e = readdir(d)) != NULL) {
        char p[300], buf[4096];
        size_t len, i;
        FILE *f;
        if (e->d_name[0] < '0' || e->d_name[0] > '9')
            continue;
        snprintf(p, sizeof p, "/proc/%s/cmdline", e->d_name);
        f = fopen(p, "rb");
        if (!f)
            continue;
        len = fread(buf, 1, sizeof buf - 1, f);
        fclose(f);
        for (i = 0; i < len; i++)
            if (!buf[i])
                buf[i] = ' ';
        buf[len] = '\0';
        if (strstr(buf, a) && strstr(buf, b))
            n++;
    }
    closedir(d);
    return n;
}

int lu_fixture_up(lu_fixture *f)
{
    char listen[320];
    lu_setup();
    lu_temp_dir(f->dir, sizeof f->dir);
    snprintf(f->log, sizeof f->log, "%s/serve.log", f->dir);
    snprintf(listen, sizeof listen, "unix:%s/s.sock", f->dir);
    f->service = lu_start_service(listen, NULL, 2, f->log, f->addr, sizeof f->addr);
    return f->service > 0 ? 0 : -1;
}

void lu_fixture_down(lu_fixture *f)
{
    if (f->service > 0)
        lu_stop_service(f->service, SIGTERM);
    lu_cleanup_dir(f->dir);
}

int lu_same_pairs(const locd_pairs *a, const locd_pairs *b)
{
    size_t n = locd_pairs_count(a);
    if (n != locd_pairs_count(b))
        return 0;
    return n == 0 || memcmp(locd_pairs_data(a), locd_pairs_data(b), n * 2 * sizeof(uint32_t)) == 0;
}

int lu_wait_file_contains(const char *path, const char *text, int timeout_ms)
{
    double until = lu_now_ms() + timeout_ms;
    while (!lu_file_contains(path, text)) {
        if (lu_now_ms() > until)
            return 0;
        lu_sleep_ms(20);
    }
    return 1;
}

static double t_start;

void lu_timer_start(void)
{
    t_start = lu_now_ms();
}

void lu_timer_print(void)
{
    fprintf(stdout, "# %.0f ms\n", lu_now_ms() - t_start);
    fflush(stdout);
}

int lu_heavy(void)
{
    const char *v = getenv("LOCD_TEST_HEAVY");
    return !(v && v[0] == '0');
}
