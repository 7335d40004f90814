#include "common/err.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int gonio_err_set(struct gonio_err *err, int code, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        err->code = code;
        va_start(ap, fmt);
        vsnprintf(err->msg, sizeof err->msg, fmt, ap);
        va_end(ap);
    }
    return -abs(code);
}

const char *gonio_strerror(int code)
{
    code = abs(code);
    switch (code) {
    case GONIO_EBADCONFIG: return "invalid configuration";
    case GONIO_EBADDATA: return "invalid data file";
    case GONIO_EUNREACHABLE: return "pair not reachable by the rig";
    case GONIO_ENOTFOUND: return "not found";
    case GONIO_EFIT: return "fit failed";
    case GONIO_EDEVICE: return "device error";
    case GONIO_EUSAGE: return "invalid usage";
    default: return strerror(code);
    }
}

int gonio_exit_status(int code)
{
    switch (abs(code)) {
    case GONIO_EBADCONFIG:
    case GONIO_EBADDATA:
    case GONIO_EUNREACHABLE:
    case GONIO_ENOTFOUND:
    case GONIO_EUSAGE:
        return 2;
    default:
        return 1;
    }
}
