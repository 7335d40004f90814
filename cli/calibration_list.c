/* gonio list's and status's lines on calibrations (cli/calibration_list.h). */
#include "cli/calibration_list.h"

#include <stdio.h>
#include <string.h>

static const char *str(json_t *e, const char *key)
{
    const char *v = json_string_value(json_object_get(e, key));
    return v ? v : "-";
}

/* An unfinished calibration continues from its journal with gonio resume
 * (a failed one is looked at first, as a failed capture is). */
static int resumable(json_t *e)
{
    const char *state = str(e, "state");
    return !strcmp(state, "interrupted") || !strcmp(state, "aborted");
}

static void resume_hint(json_t *e, const char *sock)
{
    if (resumable(e))
        printf("  resume it with: gonio resume %s%s%s\n", str(e, "id"),
               sock ? " --socket " : "", sock ? sock : "");
}

/* "16/16", "30" (unfinished: its total is known only while it runs). */
static void frames(json_t *e, char *out, size_t size)
{
    json_t *total = json_object_get(e, "frames_total");
    long long done = (long long)json_integer_value(json_object_get(e, "frames_done"));
    if (json_is_integer(total))
        snprintf(out, size, "%lld/%lld", done, (long long)json_integer_value(total));
    else
        snprintf(out, size, "%lld", done);
}

void calibration_list_table(json_t *calibrations, const char *sock)
{
    if (!json_array_size(calibrations))
        return;
    printf("\n%-34s %-10s %-11s %9s  %-12s %-16s  %-20s  %s\n", "CALIBRATION", "KIND",
           "STATE", "FRAMES", "RIG", "DETECTOR", "CREATED", "EXPIRES");
    size_t i;
    json_t *e;
    json_array_foreach(calibrations, i, e) {
        char n[48];
        frames(e, n, sizeof n);
        printf("%-34s %-10s %-11s %9s  %-12s %-16s  %-20s  %s\n", str(e, "id"), str(e, "kind"),
               str(e, "state"), n, str(e, "rig"), str(e, "detector"), str(e, "created"),
               str(e, "expires"));
        resume_hint(e, sock);
    }
}

void calibration_list_newest(json_t *newest, const char *sock)
{
    if (!json_is_object(newest))
        return;
    char n[48];
    frames(newest, n, sizeof n);
    printf("newest calibration %s (%s): %s, %s frames, rig %s, detector %s, created %s\n",
           str(newest, "id"), str(newest, "kind"), str(newest, "state"), n,
           str(newest, "rig"), str(newest, "detector"), str(newest, "created"));
    const char *msg = str(newest, "message");
    if (strcmp(msg, "-") && *msg)
        printf("  %s\n", msg);
    resume_hint(newest, sock);
}
