/* Where the tool takes a level-3 shared secret from: --secret-file PATH,
 * the LOCD_SECRET environment variable, or --secret S. The last one is
 * still accepted but warned about: any local user reads a command line in
 * /proc/PID/cmdline (and `ps`). The tool copies it and overwrites its
 * argument, which shortens that window without closing it. */
#include "cli.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Longest secret the protocol carries (lib/service: LC_PROTO_MAX_SECRET). */
#define CLI_MAX_SECRET 1024

/* The secret in path: its first line, without the line end. Exits on an
 * unreadable, empty or too long file; warns when others may read it. */
static char *secret_from_file(const char *cmd, const char *path)
{
    char buf[CLI_MAX_SECRET + 2];
    struct stat sb;
    size_t len;
    FILE *f = fopen(path, "r");
    if (!f)
        cli_die("%s: cannot open --secret-file %s: %s", cmd, path, strerror(errno));
    if (fstat(fileno(f), &sb) == 0 && S_ISDIR(sb.st_mode)) {
        fclose(f);
        cli_die("%s: --secret-file %s is a directory", cmd, path);
    }
    if (fstat(fileno(f), &sb) == 0 && (sb.st_mode & 077))
        fprintf(stderr, "locd %s: warning: %s can be read by other users (mode %03o); chmod 600 it\n", cmd, path,
                (unsigned)(sb.st_mode & 0777));
    len = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[len] = '\0';
    len = strcspn(buf, "\r\n");
    buf[len] = '\0';
    if (len == 0)
        cli_die("%s: --secret-file %s holds no secret (its first line is empty)", cmd, path);
    if (len > CLI_MAX_SECRET)
        cli_die("%s: the secret in %s is longer than %d bytes", cmd, path, CLI_MAX_SECRET);
    return strdup(buf);
}

char *cli_secret(const char *cmd, char *arg, const char *file)
{
    const char *env = getenv("LOCD_SECRET");
    char *s;
    if (file && arg)
        cli_die("%s: give --secret-file or --secret, not both", cmd);
    if (file)
        return secret_from_file(cmd, file);
    if (arg) {
        fprintf(stderr, "locd %s: warning: a secret on the command line can be read by every local user "
                        "(/proc/PID/cmdline); use --secret-file PATH or LOCD_SECRET\n",
                cmd);
        s = strdup(arg);
        memset(arg, 'x', strlen(arg)); /* hide it from later readers of the command line */
        if (!s)
            cli_die("%s: out of memory", cmd);
        return s;
    }
    if (env && env[0]) {
        if (strlen(env) > CLI_MAX_SECRET)
            cli_die("%s: LOCD_SECRET is longer than %d bytes", cmd, CLI_MAX_SECRET);
        return strdup(env);
    }
    return NULL;
}
