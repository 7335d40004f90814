/* Who may use goniod's control socket (docs/goniod.md, Security).
 *
 * The socket file's mode (0660) and folder (0750) are the first fence; the
 * kernel's record of the connecting process (SO_PEERCRED, SO_PEERGROUPS) is
 * the second, so a socket made reachable by mistake (a chmod, a bind mount,
 * an inherited descriptor) still serves only: root, goniod's own user, and
 * members of the allowed group (socket.group, else goniod's group). */
#ifndef GONIO_DAEMON_PEER_H
#define GONIO_DAEMON_PEER_H

#include <stddef.h>
#include <sys/types.h>

#define PEER_MAX_GROUPS 256

struct peer_cred {
    pid_t pid;
    uid_t uid;
    gid_t gid;                       /* primary group */
    gid_t groups[PEER_MAX_GROUPS];   /* supplementary groups, as far as they fit */
    size_t n_groups;
};

/* The credentials of the process at the other end of the connected Unix
 * socket fd, as they were when it connected. Returns 0, or -errno. */
int peer_cred_get(int fd, struct peer_cred *pc);

/* Whether pc may talk to a daemon running as self_uid that allows
 * allowed_gid: root, self_uid, or allowed_gid among pc's groups. */
int peer_allowed(const struct peer_cred *pc, uid_t self_uid, gid_t allowed_gid);

#endif
