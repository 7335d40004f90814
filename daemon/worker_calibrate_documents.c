/* A goniod calibration's run as event-model documents (capture/
 * cal_documents.h): built in the worker's thread as the run ends, from
 * every frame its journal holds, written beside them and handed to the
 * control thread with the stop for its event-model watchers. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "capture/cal_documents.h"
#include "daemon/worker_private.h"
#include "modbus_map/modbus_map.h"

/* The detector's register or device, as a capture's descriptor names it
 * (daemon/control_events.c). */
static void source(const struct goniod_config *cfg, char *out, size_t size)
{
    if (cfg->driver == GONIOD_DRIVER_SIM)
        snprintf(out, size, "gonio-sim:detector channels");
    else if (cfg->detector == GONIOD_DETECTOR_USB)
        snprintf(out, size, "usb:%04x:%04x spectrometer bands", (unsigned)cfg->usb.vendor,
                 (unsigned)cfg->usb.product);
    else if (cfg->driver == GONIOD_DRIVER_MODBUS_RTU)
        snprintf(out, size, "modbus-rtu:%s slave %d register 0x%02X (channels)", cfg->device,
                 cfg->slaves.detector, MB_DET_CHANNELS);
    else
        snprintf(out, size, "modbus-tcp:%s:%d slave %d register 0x%02X (channels)", cfg->host,
                 cfg->port, cfg->slaves.detector, MB_DET_CHANNELS);
}

struct lines {
    char *text;
    size_t len;
};

static void collect(void *user, const char *line)
{
    struct lines *l = user;
    size_t n = strlen(line);
    char *t = realloc(l->text, l->len + n + 2);
    if (!t)
        return;
    memcpy(t + l->len, line, n);
    t[l->len + n] = '\n';
    t[l->len + n + 1] = 0;
    l->text = t;
    l->len += n + 1;
}

char *worker_calibration_documents(worker *w, const struct cal_meta *meta,
                                   const struct cal_frame *frames, size_t n, size_t total,
                                   int rc, int aborted, const struct gonio_err *err,
                                   double t_start)
{
    char src[512];
    source(w->cfg, src, sizeof src);
    pthread_mutex_lock(&w->mu);
    char reason[GONIO_ERR_MSG_MAX];
    snprintf(reason, sizeof reason, "%s",
             rc < 0 ? err->msg : aborted ? (w->abort_reason[0] ? w->abort_reason : "aborted")
                                         : "complete");
    pthread_mutex_unlock(&w->mu);
    struct cal_doc_run r = {.meta = meta, .frames = frames, .n = n, .total = total,
                            .plan = meta->kind != CAL_DARK ? w->cal.plan : NULL,
                            .per_point = w->cal.per_point, .source = src,
                            .exit_status = rc < 0 ? "fail" : aborted ? "abort" : "success",
                            .reason = reason, .t_start = t_start,
                            .t_stop = cal_documents_now()};
    struct lines l = {0};
    struct gonio_err werr = {0};
    if (cal_documents(w->cfg->calibration_root, &r, collect, &l, &werr) < 0)
        fprintf(stderr, "goniod: calibration %s: %s\n", meta->id, werr.msg);
    return l.text;
}
