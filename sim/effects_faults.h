/* Communication faults: the one decision a transport asks per exchange
 * (request and reply). Both the in-process driver (drivers/drv_sim.c) and
 * gonio-sim's Modbus server use it, so a scene's fault rates mean the same
 * thing on either path.
 *
 *   enum sim_fault kind;
 *   sim_faults_next(faults, &kind);
 *   switch (kind) {
 *   case SIM_FAULT_NONE:    answer normally
 *   case SIM_FAULT_DROP:    send nothing (the client times out)
 *   case SIM_FAULT_CORRUPT: send the reply with a damaged CRC/checksum
 *   case SIM_FAULT_LATE:    send the reply after sim_faults_timeout()
 *   }
 *
 * The in-process driver turns DROP and LATE into a timeout that costs
 * timeout_s of rig time, CORRUPT into a detected bad reply, and retries up
 * to sim_faults_retries() times before failing with GONIO_EDEVICE. The
 * decision comes from the comm_faults effect's own random stream: one
 * uniform draw per exchange. */
#ifndef GONIO_SIM_EFFECTS_FAULTS_H
#define GONIO_SIM_EFFECTS_FAULTS_H

enum sim_fault { SIM_FAULT_NONE, SIM_FAULT_DROP, SIM_FAULT_CORRUPT, SIM_FAULT_LATE };

typedef struct sim_faults sim_faults;

/* Decide the next exchange's fate; returns *kind as an int too. */
int sim_faults_next(sim_faults *f, enum sim_fault *kind);

/* Seconds a dropped or late reply costs the client (its timeout). */
double sim_faults_timeout(const sim_faults *f);

/* Attempts a client makes after the first before giving up. */
int sim_faults_retries(const sim_faults *f);

/* "dropped", "corrupted", "late" ("none"). */
const char *sim_fault_name(enum sim_fault kind);

/* Counts of exchanges decided so far, by kind (index enum sim_fault). */
void sim_faults_counts(const sim_faults *f, long counts[4]);

#endif
