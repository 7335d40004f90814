/* The speeds a serial line (and so a pseudo-terminal) can be set to, as
 * termios codes and in baud. The Modbus RTU driver reads back the speed
 * its line was set to, and gonio-sim the speed its master set. */
#ifndef GONIO_COMMON_LINE_SPEED_H
#define GONIO_COMMON_LINE_SPEED_H

#include <termios.h>

/* The termios code of baud into *code: 0, or -1 when no line runs at it. */
int line_speed_code(long baud, speed_t *code);

/* The baud of a termios code; 0 when it is none of the table's. */
long line_speed_baud(speed_t code);

#endif
