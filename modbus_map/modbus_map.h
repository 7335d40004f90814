/* The rig's Modbus register map (docs/protocol-modbus.md): the one
 * contract between the Modbus drivers (drivers/drv_modbus_*.c), gonio-sim's
 * server (sim/modbus_server.c) and the drivers' fuzzer (fuzz/fuzz_modbus.c).
 * Slave ids, register addresses, command and status bits, alarm codes, and
 * the codec of 32-bit values and floats. Header-only and without
 * dependencies, so that the drivers and the simulator share it without
 * either depending on the other (docs/architecture.md). */
#ifndef GONIO_MODBUS_MAP_H
#define GONIO_MODBUS_MAP_H

#include <stdint.h>
#include <string.h>

/* The rig's devices and their usual slave ids on its one bus. */
enum mb_slave { MB_SLAVE_SAMPLE = 1, MB_SLAVE_ARM = 2, MB_SLAVE_DETECTOR = 3,
                MB_SLAVE_AZIMUTH = 4, MB_SLAVE_ROTATION = 5, MB_SLAVE_CHANGER = 6 };

/* Axis drives (AZ style). Every value is 32 bits: the first of its two
 * registers. The direct-data block runs from MB_AX_DATA_NO to the trigger. */
enum mb_axis_reg {
    MB_AX_DATA_NO = 0x58, MB_AX_OP_TYPE = 0x5A, MB_AX_POSITION = 0x5C, MB_AX_SPEED = 0x5E,
    MB_AX_ACCEL = 0x60, MB_AX_DECEL = 0x62, MB_AX_CURRENT = 0x64, MB_AX_TRIGGER = 0x66,
    MB_AX_INPUT = 0x7C, MB_AX_STATUS = 0x7E, MB_AX_ALARM = 0x80, MB_AX_FEEDBACK = 0xCC,
    MB_AX_NREGS = 0xCE, /* a drive maps registers 0 .. MB_AX_NREGS - 1 */
};
/* Input command bits (MB_AX_INPUT), acting on a 0 -> 1 edge. */
enum { MB_IN_ZHOME = 1u << 4, MB_IN_STOP = 1u << 5, MB_IN_ALM_RST = 1u << 7 };
/* Output status bits (MB_AX_STATUS). */
enum { MB_ST_HOME_END = 1u << 4, MB_ST_READY = 1u << 5, MB_ST_ALM_A = 1u << 7,
       MB_ST_MOVE = 1u << 13, MB_ST_IN_POS = 1u << 14 };
/* Present-alarm codes (MB_AX_ALARM; 0: none), as the AZ manual numbers
 * them: excessive position deviation, sensor error, overload, software
 * overtravel, abnormal operation data. */
enum mb_alarm { MB_ALARM_DEVIATION = 0x10, MB_ALARM_SENSOR = 0x28, MB_ALARM_OVERLOAD = 0x30,
                MB_ALARM_OVERTRAVEL = 0x66, MB_ALARM_DATA = 0x70 };

/* The detector (our own map). Channel k is the float at MB_DET_CHANNELS +
 * 2k. The channels follow the clock without a gap, so that one read of
 * 0x00 .. the last channel answers integration used, status, sequence,
 * clock and the reading at once. */
enum mb_det_reg {
    MB_DET_INTEGRATION = 0x00, MB_DET_TRIGGER = 0x02, MB_DET_STATUS = 0x04, MB_DET_COUNT = 0x06,
    MB_DET_SEQUENCE = 0x08, MB_DET_CLOCK = 0x0A, MB_DET_CHANNELS = 0x0C,
    /* A simulated clock's wait (write only; mapped only while the status
     * says MB_DET_CLOCK_SIMULATED): writing N lets N us of rig time pass.
     * A page of its own, clear of the channels (64 at most: up to 0x8B)
     * and of the blocks a detector keeps above them. */
    MB_DET_WAIT = 0x0200,
};
/* Detector status bits (MB_DET_STATUS). RAW: the channels of the data
 * hold counts (uint32, ADU) and the raw block describes them. BANDS (with
 * RAW): a spectral detector, whose band block holds each band's counts.
 * CLOCK_SIMULATED: the clock register counts simulated time that advances
 * only by what the simulator models, never by wall time (gonio-sim --clock
 * simulated); LINE_TIMED with it: that time includes each RTU frame's time
 * on the line at its baud (gonio-sim --baud). Both at the top of the low
 * word, clear of the detector's own state bits. */
enum { MB_DET_BUSY = 1u << 0, MB_DET_READY = 1u << 1, MB_DET_SATURATED = 1u << 2,
       MB_DET_RAW = 1u << 3, MB_DET_BANDS = 1u << 4, MB_DET_LINE_TIMED = 1u << 14, MB_DET_CLOCK_SIMULATED = 1u << 15 };
/* The detector's raw block: what a raw reading's counts need beside them,
 * in one read of MB_DET_RAW_NREGS registers (a size no other read of the
 * drivers has), and the shutter. The sequence is that of the integration
 * the block describes; no monitor reads MB_DET_MONITOR_NONE. */
enum mb_det_raw_reg {
    MB_DET_RAW_SEQUENCE = 0x0100, MB_DET_GAIN_STATE = 0x0102, MB_DET_FULL_SCALE = 0x0104,
    MB_DET_NONLINEARITY = 0x0106, MB_DET_MONITOR = 0x0108, MB_DET_SHUTTER = 0x010A,
    MB_DET_RAW_END = 0x010C, MB_DET_RAW_NREGS = MB_DET_RAW_END - MB_DET_RAW_SEQUENCE,
};
/* A spectral detector's band block (raw mode): the band count and each
 * band's centre (float32 nm) at 0x0300, read once; each raw reading's band
 * counts (uint32 ADU) with its sequence at 0x0400, one read of 2 + 2N
 * registers. At most MB_DET_MAX_BANDS bands: that read stays within a
 * Modbus read's 125 registers. */
enum mb_det_band_reg {
    MB_DET_BAND_COUNT = 0x0300, MB_DET_BAND_NM = 0x0302,
    MB_DET_BAND_SEQUENCE = 0x0400, MB_DET_BAND_COUNTS = 0x0402,
};
#define MB_DET_MAX_BANDS 61
#define MB_DET_MONITOR_NONE 0xFFFFFFFFu
#define MB_DET_GAIN_STATE_MAX 255u /* gain states a detector may number */

/* The sample changer (our own map): the slot to hold in the sample's
 * place (written; a write starts the swap), the status, and the slot in
 * place now. Slots: MB_CH_SLOT_SAMPLE, MB_CH_SLOT_STANDARD, MB_CH_SLOT_TRAP
 * (a light trap, what a stray-light calibration reads). */
enum mb_changer_reg { MB_CH_TARGET = 0x00, MB_CH_STATUS = 0x02, MB_CH_AT = 0x04, MB_CH_NREGS = 0x06 };
enum { MB_CH_SLOT_SAMPLE = 0, MB_CH_SLOT_STANDARD = 1, MB_CH_SLOT_TRAP = 2, MB_CH_SLOTS = 3 };
enum { MB_CH_BUSY = 1u << 0, MB_CH_IN_POS = 1u << 1 };

/* 32-bit values as two registers, upper word first (the AZ convention). */
static inline uint32_t mb_get32(const uint16_t *r)
{
    return ((uint32_t)r[0] << 16) | r[1];
}

static inline void mb_put32(uint16_t *r, uint32_t v)
{
    r[0] = (uint16_t)(v >> 16);
    r[1] = (uint16_t)(v & 0xFFFFu);
}

/* Floats: IEEE-754 binary32 bit patterns packed as a 32-bit value (by
 * hand: Debian's libmodbus 3.1.6 float helpers do not round-trip). */
static inline float mb_get_float(const uint16_t *r)
{
    uint32_t bits = mb_get32(r);
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
}

static inline void mb_put_float(uint16_t *r, float f)
{
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    mb_put32(r, bits);
}

#endif
