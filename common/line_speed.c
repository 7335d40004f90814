#include "common/line_speed.h"

#include <stddef.h>

static const struct {
    speed_t code;
    long baud;
} rates[] = {
    {B50, 50},         {B75, 75},         {B110, 110},       {B134, 134},
    {B150, 150},       {B200, 200},       {B300, 300},       {B600, 600},
    {B1200, 1200},     {B1800, 1800},     {B2400, 2400},     {B4800, 4800},
    {B9600, 9600},     {B19200, 19200},   {B38400, 38400},   {B57600, 57600},
    {B115200, 115200}, {B230400, 230400}, {B460800, 460800}, {B500000, 500000},
    {B576000, 576000}, {B921600, 921600}, {B1000000, 1000000},
};

int line_speed_code(long baud, speed_t *code)
{
    for (size_t i = 0; i < sizeof rates / sizeof *rates; i++)
        if (rates[i].baud == baud) {
            *code = rates[i].code;
            return 0;
        }
    return -1;
}

long line_speed_baud(speed_t code)
{
    for (size_t i = 0; i < sizeof rates / sizeof *rates; i++)
        if (rates[i].code == code)
            return rates[i].baud;
    return 0;
}
