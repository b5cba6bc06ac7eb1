/* The service, its listening socket: a Unix socket in a directory private
 * to the user (others could otherwise connect), or a TCP port. */
#include "service/service.h"

#include <errno.h>
#include <netdb.h>
#include <stdio.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

/* The directory that holds path, created 0700 when missing, and refused
 * when another user could enter it. */
static locd_status private_dir(const char *path)
{
    char dir[sizeof(((struct sockaddr_un *)0)->sun_path)];
    char *slash;
    struct stat sb;
    snprintf(dir, sizeof dir, "%s", path);
    slash = strrchr(dir, '/');
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else if (slash == dir)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "put the socket in a private directory, not in /");
    else
        *slash = '\0';
    if (stat(dir, &sb) != 0) {
        if (errno != ENOENT || mkdir(dir, 0700) != 0 || stat(dir, &sb) != 0)
            return lc_error(LOCD_ERR_IO, "cannot create the socket directory %s: %s", dir, strerror(errno));
    }
    if (!S_ISDIR(sb.st_mode) || sb.st_uid != geteuid() || (sb.st_mode & 077))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT,
                        "the socket directory %s must belong to this user with mode 0700 (others could connect)",
                        dir);
    return LOCD_OK;
}

/* A leftover socket of a dead service is replaced; a live one is not. */
static locd_status clear_stale_socket(const char *path, const struct sockaddr_un *sa)
{
    struct stat sb;
    int probe;
    if (lstat(path, &sb) != 0)
        return LOCD_OK;
    if (!S_ISSOCK(sb.st_mode))
        return lc_error(LOCD_ERR_IO, "%s exists and is not a socket", path);
    probe = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (probe >= 0 && connect(probe, (const struct sockaddr *)sa, sizeof *sa) == 0) {
        close(probe);
        return lc_error(LOCD_ERR_IO, "a service is already listening on %s", path);
    }
    if (probe >= 0)
        close(probe);
    unlink(path);
    return LOCD_OK;
}

static locd_status listen_unix(lc_server *s, const char *path)
{
    struct sockaddr_un sa;
    locd_status st;
    int fd;
    if ((st = private_dir(path)) != LOCD_OK)
        return st;
    memset(&sa, 0, sizeof sa);
    sa.sun_family = AF_UNIX;
    memcpy(sa.sun_path, path, strlen(path) + 1);
    if ((st = clear_stale_socket(path, &sa)) != LOCD_OK)
        return st;
    fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0 || bind(fd, (struct sockaddr *)&sa, sizeof sa) != 0 || chmod(path, 0600) != 0 ||
        listen(fd, LC_SRV_LISTEN_BACKLOG) != 0) {
        int err = errno;
        if (fd >= 0)
            close(fd);
        return lc_error(LOCD_ERR_IO, "cannot listen on unix:%s: %s", path, strerror(err));
    }
    s->lfd = fd;
    snprintf(s->unix_path, sizeof s->unix_path, "%s", path);
    snprintf(s->address, sizeof s->address, "unix:%s", path);
    return LOCD_OK;
}

/* A listening socket on the first address of res that binds; -1 if none. */
static int bind_first(const struct addrinfo *res)
{
    const struct addrinfo *ai;
    int fd, one = 1;
    for (ai = res; ai; ai = ai->ai_next) {
        fd = socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC, ai->ai_protocol);
        if (fd < 0)
            continue;
        setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
        if (bind(fd, ai->ai_addr, ai->ai_addrlen) == 0 && listen(fd, LC_SRV_LISTEN_BACKLOG) == 0)
            return fd;
        close(fd);
    }
    return -1;
}

static locd_status listen_tcp(lc_server *s, const lc_address *a)
{
    struct addrinfo hints, *res = NULL;
    struct sockaddr_storage ss;
    socklen_t sl = sizeof ss;
    char host[NI_MAXHOST], port[NI_MAXSERV];
    int fd, rc;
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_PASSIVE;
    if ((rc = getaddrinfo(a->host, a->port, &hints, &res)) != 0)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "tcp:%s:%s: %s", a->host, a->port, gai_strerror(rc));
    fd = bind_first(res);
    freeaddrinfo(res);
    if (fd < 0)
        return lc_error(LOCD_ERR_IO, "cannot listen on tcp:%s:%s: %s", a->host, a->port, strerror(errno));
    /* Port 0 means any free port: report the one actually bound. */
    getsockname(fd, (struct sockaddr *)&ss, &sl);
    getnameinfo((struct sockaddr *)&ss, sl, host, sizeof host, port, sizeof port, NI_NUMERICHOST | NI_NUMERICSERV);
    s->lfd = fd;
    snprintf(s->address, sizeof s->address, "tcp:%.200s:%.16s", host, port);
    return LOCD_OK;
}

locd_status lc_srv_listen(lc_server *s, const lc_address *a)
{
    return a->tcp ? listen_tcp(s, a) : listen_unix(s, a->path);
}
