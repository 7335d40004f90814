#define _GNU_SOURCE /* struct ucred */
#include "daemon/peer.h"

#include <errno.h>
#include <string.h>
#include <sys/socket.h>

int peer_cred_get(int fd, struct peer_cred *pc)
{
    memset(pc, 0, sizeof *pc);
    struct ucred uc;
    socklen_t len = sizeof uc;
    if (getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &uc, &len) < 0)
        return -errno;
    pc->pid = uc.pid;
    pc->uid = uc.uid;
    pc->gid = uc.gid;
#ifdef SO_PEERGROUPS
    /* Supplementary groups (Linux 4.13+): an operator is usually in the
     * group through them, not through the primary group. A peer in more
     * than PEER_MAX_GROUPS groups gets ERANGE and is judged on its uid and
     * primary group alone (refused unless those allow it). */
    len = sizeof pc->groups;
    if (getsockopt(fd, SOL_SOCKET, SO_PEERGROUPS, pc->groups, &len) == 0)
        pc->n_groups = len / sizeof pc->groups[0];
#endif
    return 0;
}

int peer_allowed(const struct peer_cred *pc, uid_t self_uid, gid_t allowed_gid)
{
    if (pc->uid == 0 || pc->uid == self_uid || pc->gid == allowed_gid)
        return 1;
    for (size_t i = 0; i < pc->n_groups && i < PEER_MAX_GROUPS; i++)
        if (pc->groups[i] == allowed_gid)
            return 1;
    return 0;
}
