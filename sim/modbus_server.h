/* gonio-sim's Modbus side: a simulated rig (sim/sim.h) behind the register
 * map of docs/protocol-modbus.md, served as one bus with several slave ids
 * over Modbus RTU on a pseudo-terminal and/or Modbus TCP on loopback.
 *
 * Slave ids, registers and alarm codes: modbus_map/modbus_map.h. The
 * rig's clock follows wall time scaled by time_scale: every request first
 * brings the rig to now, so motion, homing and integration advance between
 * requests exactly as they would on a real rig, only faster. Or it is
 * simulated (msim_cfg.simulated_clock): it advances only by what the
 * simulator models, and a read that polls for a move's or an
 * integration's end finds it ended, the clock moved on to that end. */
#ifndef GONIO_SIM_MODBUS_SERVER_H
#define GONIO_SIM_MODBUS_SERVER_H

#include <signal.h>
#include <stddef.h>
#include <stdio.h>

#include "brdf/material.h"
#include "common/err.h"
#include "rig/rig.h"

struct msim_cfg {
    /* Bus costs, in rig time (so each is waited time_scale times shorter
     * in wall time; docs/gonio-sim.md "Line time"): an RTU exchange takes
     * its frames' time on a serial line at baud (11 bits a character, and
     * the inter-frame silence after each frame; 0: free), a TCP reply
     * tcp_latency_s (0: none). A device on a wire at baud (> 0) hears
     * only a master at that speed: an RTU frame arriving while the line
     * settings the master set on the pseudo-terminal say another speed is
     * what a real device makes of it, framing errors, and gets no answer. */
    long baud;
    double tcp_latency_s;
    double time_scale;    /* simulated seconds per wall second, > 0 */
    /* The clock: 0 follows wall time scaled by time_scale; 1 (simulated)
     * advances only by what the simulator models: moves, integrations,
     * the bus's time above, late answers and the wait register
     * (docs/gonio-sim.md "The simulated clock"). */
    int simulated_clock;
    double steps_per_deg; /* drive steps per degree, > 0 */
    /* The drives' positioning completion band, load degrees: IN-POS turns
     * on when an operation has ended with the motor this close to its
     * target (the AZ's "IN-POS positioning completion signal range";
     * docs/protocol-modbus.md). 0: half a step. */
    double in_pos_deg;
    int trace;            /* one stderr line per request */
    /* The detector has no shutter register (0x010A): reading or writing
     * it gets exception 02, as from a detector built without one. */
    int no_shutter;
};

typedef struct msim msim;

struct sim_scene;

/* Profile and material must outlive the server; the scene (NULL: no
 * effects) is copied. The scene's effects apply as in the offline capture:
 * the detector reads through them (noise, auto-exposure, saturation), move
 * effects (jitter, backlash, stall) act on the axes, and comm_faults drops,
 * corrupts or delays exchanges. The azimuth slave exists only when the
 * profile is out_of_plane, the rotation slave only when it has a rotation
 * axis (axes.rotation); the detector reads the material turned by the
 * rotation drive's position (sim/sim.h). */
msim *msim_new(const struct rig_profile *profile, const brdf_material *material,
               const struct sim_scene *scene, const struct msim_cfg *cfg,
               struct gonio_err *err);
void msim_free(msim *m);

/* Fault injection: an obstacle at deg on the axis at slave. A move across
 * it halts there; MSIM_JAM_STALL keeps the drive reporting MOVE with no
 * alarm (the master must notice the lack of progress), MSIM_JAM_OVERLOAD
 * raises alarm 0x30 as the axis halts. STOP ends a stalled move. */
enum msim_jam_kind { MSIM_JAM_NONE, MSIM_JAM_STALL, MSIM_JAM_OVERLOAD };
int msim_jam(msim *m, int slave, enum msim_jam_kind kind, double deg, struct gonio_err *err);

/* Fault injection: the slave answers ms milliseconds late, holding up the
 * whole server meanwhile, as a slow device holds a bus. */
int msim_delay(msim *m, int slave, double ms, struct gonio_err *err);

/* 1 when baud is a speed a serial line can be set to (termios: 50 to
 * 1000000), else 0: msim_cfg.baud must be one. */
int msim_line_speed(long baud);

/* Create the RTU pseudo-terminal (raw mode); its slave path goes to path.
 * link, when not NULL, is (re)made a symlink to it. */
int msim_open_pty(msim *m, const char *link, char *path, size_t size, struct gonio_err *err);

/* Listen for Modbus TCP on addr ("127.0.0.1:PORT", IPv4; PORT 0 picks a
 * free one); the port actually bound goes to *port. */
int msim_open_tcp(msim *m, const char *addr, int *port, struct gonio_err *err);

/* What the rig saw, as one JSON object: exchanges with present slaves,
 * the comm_faults injected by kind, the detector's exchanges, and per axis
 * its exchanges, the moves started, the commands refused (beyond the
 * limits: alarm 0x66), the rig profile's limits, the range of commanded
 * targets, the range of positions the axis took, and the alarms raised. A
 * fault soak holds the drivers to these; make bench reports the exchanges
 * per device. */
void msim_write_stats(const msim *m, FILE *out);

/* Answer requests until *stop becomes non-zero (a signal handler sets it).
 * Whenever *hangup is non-zero the server closes every TCP connection (a
 * network drop) and clears it. Malformed input is answered or ignored as a
 * real slave would; only a failure of the server's own descriptors ends it
 * early. */
int msim_serve(msim *m, volatile sig_atomic_t *stop, volatile sig_atomic_t *hangup,
               struct gonio_err *err);

#endif
