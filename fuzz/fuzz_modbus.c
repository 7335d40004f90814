/* Modbus replies as the drivers see them (drivers/drv_modbus_*.c): the
 * real axis, detector and clock drivers over a scripted bus whose every
 * reply comes from the fuzz input. libmodbus checks the frames; what is
 * fuzzed here is what the drivers make of well-formed replies with any
 * register values, any failures, in any order, on a virtual clock (so
 * timeouts and stall detection run without sleeping).
 *
 * Input: byte 0 picks the time scale, backlash, clock, tries (the axis
 * mechanics' re-commands and alarm recoveries) and approach, then a script of
 * operations (one byte each, with an argument byte); each bus transaction
 * takes one byte (0xFF: the transaction fails) and, for a read, two bytes
 * a register. When the input runs out every transaction fails.
 *
 * Invariants: a move is never commanded outside the axis's soft limits;
 * an accepted reading is finite, non-negative in integration time, and a
 * position read back is finite. */
#include <errno.h>
#include <math.h>

#include "drivers/drv_modbus.h"
#include "drivers/drv_modbus_private.h"
#include "fuzz/fuzz.h"

struct drv_modbus_bus {
    const uint8_t *data;
    size_t size, pos;
    double now, scale, timeout;
    double steps_per_deg;
    double min_deg, max_deg; /* soft limits of the axis on slave 1 */
    long exchanges;           /* as the real bus's request count */
    long faults;              /* failed transactions (drv_modbus_faults) */
    int clock_slave;          /* drv_modbus_note_clock, as the real bus keeps it */
    uint32_t clock_ms;
    double clock_wall;
    long clock_exchanges;
    double sent, answered; /* the last transaction (drv_modbus_acted) */
    int simulated_clock;   /* a status read with MB_DET_CLOCK_SIMULATED set it */
};

static int next_byte(drv_modbus_bus *bus, uint8_t *b)
{
    if (bus->pos >= bus->size)
        return -1;
    *b = bus->data[bus->pos++];
    return 0;
}

static int transaction(drv_modbus_bus *bus, const char *who, struct gonio_err *err)
{
    uint8_t b;
    bus->exchanges++;
    bus->sent = bus->now;
    bus->now += 0.001; /* a round trip takes time on the virtual clock */
    bus->answered = bus->now;
    if (next_byte(bus, &b) < 0 || b == 0xFF) {
        bus->faults++;
        return gonio_err_set(err, ETIMEDOUT, "%s: no answer (fuzz)", who);
    }
    return 0;
}

long drv_modbus_faults(const drv_modbus_bus *bus)
{
    return bus->faults;
}

int drv_modbus_read(drv_modbus_bus *bus, int slave, int addr, int n, uint16_t *out,
                    const char *who, struct gonio_err *err)
{
    (void)slave, (void)addr;
    FUZZ_CHECK(n > 0 && n <= 125); /* a Modbus read holds at most 125 registers */
    int rc = transaction(bus, who, err);
    if (rc < 0)
        return rc;
    for (int i = 0; i < n; i++) {
        uint8_t hi = 0, lo = 0;
        if (next_byte(bus, &hi) < 0 || next_byte(bus, &lo) < 0)
            return gonio_err_set(err, ETIMEDOUT, "%s: short answer (fuzz)", who);
        out[i] = (uint16_t)(hi << 8 | lo);
    }
    return 0;
}

int drv_modbus_write(drv_modbus_bus *bus, int slave, int addr, int n, const uint16_t *regs,
                     const char *who, struct gonio_err *err)
{
    FUZZ_CHECK(n > 0 && n <= 123); /* a Modbus write holds at most 123 registers */
    /* Direct-data operation of the axis: the target position must be
     * within the soft limits, whichever write of the block carries it. */
    int at = MB_AX_POSITION - addr;
    if (slave == MB_SLAVE_SAMPLE && at >= 0 && n >= at + 2) {
        double target = (double)(int32_t)mb_get32(regs + at) / bus->steps_per_deg;
        FUZZ_CHECK(target >= bus->min_deg - 1.0 / bus->steps_per_deg &&
                   target <= bus->max_deg + 1.0 / bus->steps_per_deg);
    }
    return transaction(bus, who, err);
}

/* A virtual line that bounds nothing: the device acted between the send
 * and the answer. */
int drv_modbus_last_exception(const drv_modbus_bus *bus)
{
    (void)bus;
    return 0; /* a scripted failure is no answer */
}

void drv_modbus_acted(const drv_modbus_bus *bus, double *lo, double *hi)
{
    *lo = bus->sent;
    *hi = bus->answered;
}

double drv_modbus_request_s(const drv_modbus_bus *bus, int write, int n)
{
    (void)bus, (void)write, (void)n;
    return 0;
}

double drv_modbus_gap_s(const drv_modbus_bus *bus)
{
    (void)bus;
    return 0;
}

double drv_modbus_time_scale(const drv_modbus_bus *bus)
{
    return bus->scale;
}

void drv_modbus_set_simulated_clock(drv_modbus_bus *bus, int line_timed)
{
    (void)line_timed;
    bus->simulated_clock = 1;
}

int drv_modbus_simulated_clock(const drv_modbus_bus *bus)
{
    return bus->simulated_clock;
}

/* The scripted bus is no serial line: its frames take no rig time. */
void drv_modbus_line_rig(const drv_modbus_bus *bus, double *acted, double *total)
{
    (void)bus;
    *acted = *total = 0;
}

void drv_modbus_line_rig_restore(drv_modbus_bus *bus, double acted, double total)
{
    (void)bus;
    (void)acted;
    (void)total;
}

double drv_modbus_request_rig_s(const drv_modbus_bus *bus, int write, int n)
{
    (void)bus;
    (void)write;
    (void)n;
    return 0;
}

double drv_modbus_timeout(const drv_modbus_bus *bus)
{
    return bus->timeout;
}

void drv_modbus_note_clock(drv_modbus_bus *bus, int slave, uint32_t ms)
{
    bus->clock_slave = slave;
    bus->clock_ms = ms;
    bus->clock_wall = bus->answered;
    bus->clock_exchanges = bus->exchanges;
}

int drv_modbus_last_clock(const drv_modbus_bus *bus, int slave, uint32_t *ms, double *lo,
                          double *hi)
{
    if (bus->clock_slave != slave || bus->clock_exchanges != bus->exchanges)
        return 0;
    *ms = bus->clock_ms;
    *lo = *hi = bus->clock_wall;
    return 1;
}

static drv_modbus_bus *the_bus;

/* The drivers read the time with gonio_monotonic_s (common/clock.h). This
 * definition takes the place of common/clock.c's at link time (an object
 * file's symbol wins over an archive member's), so that their deadlines,
 * pacing and stall detection run on the virtual clock, as their sleeps do;
 * on the real clock every wait would only end by running out of input. */
double gonio_monotonic_s(void)
{
    return the_bus ? the_bus->now : 0.0;
}

int drv_modbus_sleep(drv_modbus_bus *bus, double seconds, const char *who,
                     struct gonio_err *err)
{
    (void)who;
    (void)err;
    if (seconds > 0)
        bus->now += seconds;
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    static const double scales[4] = {1.0, 10.0, 100.0, 1000.0};
    drv_modbus_bus bus = {.data = data, .size = size, .pos = 1, .now = 1000.0,
                          .scale = scales[data[0] & 3], .timeout = 0.05,
                          .steps_per_deg = 100.0, .min_deg = -5.0, .max_deg = 95.0};
    the_bus = &bus;
    struct rig_axis prof = {.speed = 20, .accel = 40, .min = bus.min_deg, .max = bus.max_deg};
    struct drv_modbus_axis_opts opts = {.steps_per_deg = bus.steps_per_deg,
                                        .backlash_deg = (data[0] & 4) ? 0.5 : 0.0,
                                        .move_retries = (data[0] & 16) ? 3 : 0,
                                        .approach = (data[0] & 32) ? -1 : 1};
    struct gonio_err err = {0};
    drv_axis *ax = drv_axis_new_modbus(&bus, MB_SLAVE_SAMPLE, &prof, &opts, "fuzz", &err);
    drv_detector *det = drv_detector_new_modbus(&bus, MB_SLAVE_DETECTOR, &err);
    FUZZ_CHECK(ax && det);
    drv_clock *clk = (data[0] & 8) ? drv_clock_new_modbus(&bus, MB_SLAVE_DETECTOR, &err) : NULL;
    uint8_t op, arg;
    while (next_byte(&bus, &op) == 0 && next_byte(&bus, &arg) == 0) {
        double deg;
        struct drv_reading rd;
        switch (op % 8) {
        case 0: /* a move anywhere, limits or not */
            if (drv_axis_start_move(ax, -20.0 + arg * 0.5, &err) == 0)
                drv_axis_wait(ax, &err);
            break;
        case 1:
            drv_axis_home(ax, &err);
            break;
        case 2:
            if (drv_axis_position(ax, &deg, &err) == 0)
                FUZZ_CHECK(isfinite(deg));
            break;
        case 3:
            if (drv_detector_acquire(det, arg * 0.01, &rd, &err) == 0) {
                for (int k = 0; k < 3; k++)
                    FUZZ_CHECK(isfinite(rd.rgb[k]));
                FUZZ_CHECK(isfinite(rd.integration_s) && rd.integration_s >= 0);
            }
            break;
        case 4:
            drv_axis_stop(ax, &err);
            break;
        case 5:
            drv_axis_alarm_reset(ax, &err);
            break;
        case 6:
            if (clk)
                FUZZ_CHECK(isfinite(drv_clock_now(clk)));
            break;
        default:
            if (clk)
                drv_clock_sleep(clk, arg * 0.1);
            break;
        }
    }
    drv_clock_free(clk);
    drv_detector_free(det);
    drv_axis_free(ax);
    the_bus = NULL;
    return 0;
}
