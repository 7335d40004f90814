/* gonio error reporting.
 *
 * Functions return 0 (or a count) on success and a negative code on failure.
 * Where a person needs the detail, they also fill an optional struct
 * gonio_err: the code and one line naming the file, field and problem.
 * gonio's own codes start above GONIO_ENOBASE, as libmodbus's do above
 * MODBUS_ENOBASE, so they never collide with errno values. */
#ifndef GONIO_COMMON_ERR_H
#define GONIO_COMMON_ERR_H

#include <stddef.h>

#define GONIO_ENOBASE 220000

enum gonio_errcode {
    GONIO_EBADCONFIG = GONIO_ENOBASE + 1, /* config, plan, scene, rig file */
    GONIO_EBADDATA,                       /* MERL table, weight file, samples */
    GONIO_EUNREACHABLE,                   /* pair outside the rig's reach */
    GONIO_ENOTFOUND,                      /* named material, plan, file */
    GONIO_EFIT,                           /* a fit that produced no usable result */
    GONIO_EDEVICE,                        /* a device failed or replied wrongly */
    GONIO_EUSAGE,                         /* bad command line */
};

#define GONIO_ERR_MSG_MAX 512

struct gonio_err {
    int code;
    char msg[GONIO_ERR_MSG_MAX];
};

/* Fill err (if not NULL) and return -code, so that callers can write
 * `return gonio_err_set(err, GONIO_EBADDATA, "%s: ...", path);`. */
int gonio_err_set(struct gonio_err *err, int code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Text for a gonio code, or strerror() for an errno value. */
const char *gonio_strerror(int code);

/* Exit status for a failure code: 2 for bad input (config, data, usage,
 * unreachable pairs, unknown names), 1 for everything else. */
int gonio_exit_status(int code);

#endif
