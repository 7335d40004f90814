/* gonio-sim's Modbus server: its lifecycle, the two transports that
 * bring requests in (RTU on a pseudo-terminal, TCP on loopback) and the
 * loop that waits on them. The devices behind the register banks are in
 * sim/modbus_devices.c, the answer to one request in sim/modbus_requests.c. */
#define _DEFAULT_SOURCE /* cfmakeraw */
#define _XOPEN_SOURCE 700 /* posix_openpt, grantpt, ptsname */
#include "sim/modbus_server.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include "common/clock.h"
#include "common/line_speed.h"
#include "sim/modbus_server_private.h"
#include "sim/sim.h"

/* ---- Lifecycle ------------------------------------------------------------- */

msim *msim_new(const struct rig_profile *profile, const brdf_material *material,
               const struct sim_scene *scene, const struct msim_cfg *cfg,
               struct gonio_err *err)
{
    if (!(cfg->time_scale > 0) || !(cfg->steps_per_deg > 0)) {
        gonio_err_set(err, GONIO_EUSAGE, "gonio-sim: time scale %g and steps per degree %g must "
                      "be positive", cfg->time_scale, cfg->steps_per_deg);
        return NULL;
    }
    msim *m = calloc(1, sizeof *m);
    if (!m) {
        gonio_err_set(err, ENOMEM, "gonio-sim: out of memory");
        return NULL;
    }
    m->cfg = *cfg;
    m->profile = profile;
    m->pty_master = m->pty_slave = m->listen_fd = -1;
    for (int i = 0; i < MAX_CLIENTS; i++)
        m->clients[i].fd = -1;
    m->rig = sim_rig_new_scene(profile, material, scene, NULL, err);
    if (!m->rig) {
        free(m);
        return NULL;
    }
    const struct rig_axis *profs[SIM_N_AXES] = {&profile->sample, &profile->arm,
                                                 &profile->azimuth, &profile->rotation};
    m->served[SIM_AXIS_SAMPLE] = m->served[SIM_AXIS_ARM] = 1;
    m->served[SIM_AXIS_AZIMUTH] = profile->out_of_plane;
    m->served[SIM_AXIS_ROTATION] = profile->has_rotation;
    for (int i = 0; i < SIM_N_AXES; i++) {
        m->axis[i].id = (enum sim_axis_id)i;
        m->axis[i].cmd_min = m->axis[i].pos_min = INFINITY;
        m->axis[i].cmd_max = m->axis[i].pos_max = -INFINITY;
        m->axis[i].prof = profs[i];
        m->axis[i].map = modbus_mapping_new_start_address(0, 0, 0, 0, 0, AX_NREGS, 0, 0);
        if (!m->axis[i].map)
            break;
    }
    m->det.map = modbus_mapping_new_start_address(0, 0, 0, 0, 0, DET_MAP_NREGS, 0, 0);
    if (!m->det.map || !m->axis[SIM_N_AXES - 1].map) {
        msim_free(m);
        gonio_err_set(err, ENOMEM, "gonio-sim: out of memory");
        return NULL;
    }
    put32(m->det.map->tab_registers, DET_COUNT, DET_NCHANNELS);
    /* A spectral detector that gives counts serves its bands too. */
    if (scene && scene->n_bands > 0 && scene->n_bands <= MB_DET_MAX_BANDS &&
        sim_rig_counts(m->rig)) {
        m->det.n_bands = scene->n_bands;
        put32(m->det.map->tab_registers, MB_DET_BAND_COUNT, (uint32_t)scene->n_bands);
        for (int k = 0; k < scene->n_bands; k++)
            mb_put_float(m->det.map->tab_registers + MB_DET_BAND_NM + 2 * k,
                         (float)scene->bands_nm[k]);
    }
    if (msim_changer_new(m, material, scene, err) < 0) {
        msim_free(m);
        return NULL;
    }
    m->wall0 = gonio_monotonic_s();
    return m;
}

void msim_free(msim *m)
{
    if (!m)
        return;
    for (int i = 0; i < SIM_N_AXES; i++)
        modbus_mapping_free(m->axis[i].map);
    modbus_mapping_free(m->det.map);
    msim_changer_free(m);
    if (m->rtu)
        modbus_free(m->rtu);
    if (m->tcp)
        modbus_free(m->tcp);
    for (int i = 0; i < MAX_CLIENTS; i++)
        if (m->clients[i].fd >= 0)
            close(m->clients[i].fd);
    if (m->listen_fd >= 0)
        close(m->listen_fd);
    if (m->pty_slave >= 0)
        close(m->pty_slave);
    if (m->pty_master >= 0)
        close(m->pty_master);
    sim_rig_free(m->rig);
    free(m);
}

/* ---- RTU on a pseudo-terminal --------------------------------------------- */

int msim_open_pty(msim *m, const char *link, char *path, size_t size, struct gonio_err *err)
{
    int fd = posix_openpt(O_RDWR | O_NOCTTY);
    if (fd < 0 || grantpt(fd) < 0 || unlockpt(fd) < 0) {
        int e = errno;
        if (fd >= 0)
            close(fd);
        return gonio_err_set(err, e, "gonio-sim: pseudo-terminal: %s", strerror(e));
    }
    m->pty_master = fd;
    const char *name = ptsname(fd);
    if (!name || strlen(name) >= size)
        return gonio_err_set(err, EIO, "gonio-sim: no name for the pseudo-terminal");
    snprintf(path, size, "%s", name);
    m->pty_slave = open(path, O_RDWR | O_NOCTTY);
    if (m->pty_slave < 0)
        return gonio_err_set(err, errno, "gonio-sim: %s: %s", path, strerror(errno));
    /* Raw bytes both ways, as on a serial line; clients set their own mode
     * too, but a client that does not must not get echoes. */
    struct termios t;
    if (tcgetattr(m->pty_slave, &t) == 0) {
        cfmakeraw(&t);
        tcsetattr(m->pty_slave, TCSANOW, &t);
    }
    fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
    m->rtu = modbus_new_rtu("/dev/null", 115200, 'N', 8, 1);
    if (!m->rtu || modbus_set_socket(m->rtu, fd) < 0)
        return gonio_err_set(err, ENOMEM, "gonio-sim: RTU context: %s", modbus_strerror(errno));
    if (link) {
        unlink(link);
        if (symlink(path, link) < 0)
            return gonio_err_set(err, errno, "gonio-sim: --link %s: %s", link, strerror(errno));
    }
    return 0;
}

/* Length of the RTU frame starting the buffer from its function code; 0:
 * not known yet, -1: a function whose length we cannot tell (the frame ends
 * at a silence). */
static int rtu_frame_len(const uint8_t *b, int n)
{
    if (n < 2)
        return 0;
    switch (b[1]) {
    case 0x01: case 0x02: case 0x03: case 0x04: case 0x05: case 0x06:
        return 8;
    case 0x0F: case 0x10:
        return n < 7 ? 0 : 9 + b[6];
    default:
        return -1;
    }
}

/* The speed the master set on the pseudo-terminal, in baud (Linux: the
 * master side reads the slave side's termios); 0 when unknown or when
 * input and output differ, -1 when tcgetattr fails. */
static long pty_line_baud(int fd)
{
    struct termios t;
    if (tcgetattr(fd, &t) < 0)
        return -1;
    speed_t out = cfgetospeed(&t), in = cfgetispeed(&t);
    if (in != 0 && in != out) /* input 0: the output's speed */
        return 0;
    return line_speed_baud(out);
}

static void rtu_frame(msim *m, int len)
{
    const uint8_t *b = m->rtu_buf;
    /* A device on a wire at cfg.baud hears a master at another speed as
     * framing errors: it answers nothing. */
    long line = m->cfg.baud > 0 ? pty_line_baud(m->pty_master) : 0;
    if (m->cfg.baud > 0 && line != m->cfg.baud) {
        if (m->cfg.trace)
            fprintf(stderr, "gonio-sim: RTU frame of %d bytes at %ld baud on a %ld-baud line "
                    "ignored\n", len, line, m->cfg.baud);
        return;
    }
    /* A frame with a bad CRC is noise: a real slave says nothing. */
    if (len < 4 || msim_crc16(b, len - 2) != (uint16_t)(b[len - 2] | (b[len - 1] << 8))) {
        if (m->cfg.trace)
            fprintf(stderr, "gonio-sim: RTU frame of %d bytes with a bad CRC ignored\n", len);
        return;
    }
    msim_handle_request(m, m->rtu, b, len, 1, len - 3);
}

/* Read what the pty holds; answer complete frames. */
static void rtu_read(msim *m)
{
    for (;;) {
        if (m->rtu_len == (int)sizeof m->rtu_buf)
            m->rtu_len = 0; /* nothing valid is that long: drop it */
        ssize_t got = read(m->pty_master, m->rtu_buf + m->rtu_len,
                           sizeof m->rtu_buf - (size_t)m->rtu_len);
        if (got <= 0)
            break;
        m->rtu_len += (int)got;
    }
    for (;;) {
        int fl = rtu_frame_len(m->rtu_buf, m->rtu_len);
        if (fl <= 0 || fl > m->rtu_len)
            return;
        if (fl > (int)sizeof m->rtu_buf) {
            m->rtu_len = 0;
            return;
        }
        int bad = msim_crc16(m->rtu_buf, fl - 2) !=
                  (uint16_t)(m->rtu_buf[fl - 2] | (m->rtu_buf[fl - 1] << 8));
        rtu_frame(m, fl);
        if (bad) { /* the rest of a noisy burst is noise too */
            m->rtu_len = 0;
            return;
        }
        memmove(m->rtu_buf, m->rtu_buf + fl, (size_t)(m->rtu_len - fl));
        m->rtu_len -= fl;
    }
}

/* A silence ended whatever is buffered. */
static void rtu_silence(msim *m)
{
    if (m->rtu_len > 0)
        rtu_frame(m, m->rtu_len);
    m->rtu_len = 0;
}

/* ---- TCP on loopback --------------------------------------------------------- */

int msim_open_tcp(msim *m, const char *addr, int *port, struct gonio_err *err)
{
    char host[64];
    const char *colon = strrchr(addr, ':');
    char *end;
    long p = colon ? strtol(colon + 1, &end, 10) : -1;
    if (!colon || (size_t)(colon - addr) >= sizeof host || *end || p < 0 || p > 65535 ||
        colon == addr)
        return gonio_err_set(err, GONIO_EUSAGE, "--tcp '%s': use HOST:PORT (PORT 0 picks one)",
                             addr);
    memcpy(host, addr, (size_t)(colon - addr));
    host[colon - addr] = '\0';
    struct in_addr ia;
    if (inet_pton(AF_INET, host, &ia) != 1)
        return gonio_err_set(err, GONIO_EUSAGE, "--tcp '%s': '%s' is not an IPv4 address", addr,
                             host);
    m->tcp = modbus_new_tcp(host, (int)p);
    if (!m->tcp)
        return gonio_err_set(err, ENOMEM, "--tcp %s: %s", addr, modbus_strerror(errno));
    m->listen_fd = modbus_tcp_listen(m->tcp, MAX_CLIENTS);
    if (m->listen_fd < 0)
        return gonio_err_set(err, errno, "--tcp %s: %s", addr, modbus_strerror(errno));
    struct sockaddr_in sa;
    socklen_t sl = sizeof sa;
    if (getsockname(m->listen_fd, (struct sockaddr *)&sa, &sl) < 0)
        return gonio_err_set(err, errno, "--tcp %s: %s", addr, strerror(errno));
    *port = ntohs(sa.sin_port);
    return 0;
}

static void tcp_accept(msim *m)
{
    int fd = accept(m->listen_fd, NULL, NULL);
    if (fd < 0)
        return;
    for (int i = 0; i < MAX_CLIENTS; i++)
        if (m->clients[i].fd < 0) {
            m->clients[i].fd = fd;
            m->clients[i].len = 0;
            return;
        }
    close(fd); /* full: refuse */
}

static void tcp_close(msim *m, int slot)
{
    close(m->clients[slot].fd);
    m->clients[slot].fd = -1;
}

/* Read what a client sent and answer each complete frame. The MBAP
 * header's length cuts the frames, as the Modbus TCP implementation guide
 * has a server do, so a PDU whose own fields disagree with it (an FC 0x10
 * byte count) gets its exception 03 and the stream stays in step. A frame
 * whose protocol id is not 0 (Modbus) is discarded unanswered; a length no
 * request can have loses the stream, and the connection is closed. */
static void tcp_read(msim *m, int slot)
{
    struct tcp_client *c = &m->clients[slot];
    ssize_t got = recv(c->fd, c->buf + c->len, sizeof c->buf - (size_t)c->len, MSG_DONTWAIT);
    if (got < 0 && (errno == EAGAIN || errno == EINTR))
        return;
    if (got <= 0) { /* the client went away */
        tcp_close(m, slot);
        return;
    }
    c->len += (int)got;
    while (c->len >= 7) {
        int n = 6 + ((c->buf[4] << 8) | c->buf[5]); /* the whole frame */
        if (n < 8 || n > TCP_MAX_ADU) {
            if (m->cfg.trace)
                fprintf(stderr, "gonio-sim: TCP frame length %d: connection closed\n", n - 6);
            tcp_close(m, slot);
            return;
        }
        if (c->len < n)
            return;
        if (c->buf[2] || c->buf[3]) {
            if (m->cfg.trace)
                fprintf(stderr, "gonio-sim: TCP frame of protocol %u discarded\n",
                        (unsigned)((c->buf[2] << 8) | c->buf[3]));
        } else {
            modbus_set_socket(m->tcp, c->fd);
            msim_handle_request(m, m->tcp, c->buf, n, 7, n - 7);
        }
        memmove(c->buf, c->buf + n, (size_t)(c->len - n));
        c->len -= n;
    }
}

/* ---- The loop -------------------------------------------------------------- */

int msim_serve(msim *m, volatile sig_atomic_t *stop, volatile sig_atomic_t *hangup,
               struct gonio_err *err)
{
    while (!*stop) {
        if (*hangup) {
            *hangup = 0;
            for (int i = 0; i < MAX_CLIENTS; i++)
                if (m->clients[i].fd >= 0)
                    tcp_close(m, i);
        }
        struct pollfd pf[2 + MAX_CLIENTS];
        int slot[2 + MAX_CLIENTS];
        int n = 0;
        if (m->pty_master >= 0)
            pf[n] = (struct pollfd){.fd = m->pty_master, .events = POLLIN}, slot[n++] = -1;
        if (m->listen_fd >= 0)
            pf[n] = (struct pollfd){.fd = m->listen_fd, .events = POLLIN}, slot[n++] = -2;
        for (int i = 0; i < MAX_CLIENTS; i++)
            if (m->clients[i].fd >= 0)
                pf[n] = (struct pollfd){.fd = m->clients[i].fd, .events = POLLIN},
                slot[n++] = i;
        int rc = poll(pf, (nfds_t)n, m->rtu_len > 0 ? RTU_GAP_MS : 200);
        if (rc < 0) {
            if (errno == EINTR)
                continue;
            return gonio_err_set(err, errno, "gonio-sim: poll: %s", strerror(errno));
        }
        if (rc == 0) {
            rtu_silence(m);
            continue;
        }
        for (int i = 0; i < n; i++) {
            if (!(pf[i].revents & (POLLIN | POLLHUP | POLLERR)))
                continue;
            if (slot[i] == -1)
                rtu_read(m);
            else if (slot[i] == -2)
                tcp_accept(m);
            else
                tcp_read(m, slot[i]);
        }
    }
    return 0;
}
