/* gonio home, move, where, limits: bring-up of a new rig through goniod
 * (docs/cli.md, docs/goniod.md "Bring-up"). goniod runs each on its
 * drives and answers when it ends; refused while a capture runs. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "cli/commands.h"
#include "cli/daemon_client.h"

static void usage(FILE *out, const char *cmd)
{
    const char *args = !strcmp(cmd, "home")     ? " [AXIS]"
                       : !strcmp(cmd, "move")   ? " AXIS DEG"
                       : !strcmp(cmd, "limits") ? " AXIS"
                                                : "";
    fprintf(out,
            "usage: gonio %s%s [--socket PATH] [--json]\n"
            "  home: home AXIS (sample, arm, azimuth or rotation), else every axis the rig has\n"
            "  move: move AXIS to DEG degrees, within the rig profile's soft limits\n"
            "  where: every axis's encoder position, drive status and alarm\n"
            "  limits: drive AXIS slowly (%g x the profile's speed) to its min and max\n"
            "  soft limits and back, to prove the rig profile on a new rig\n"
            "  Each prints where the axes stand once it ended (--json: goniod's reply).\n"
            "  Needs goniod on a Modbus rig; refused while a capture runs.\n"
            "  gonio abort (from another terminal) ends it: the axes stop where they\n"
            "  are, it prints 'aborted' and that table, and exits 1.\n"
            "  The socket is --socket, else $GONIO_SOCKET, else " GONIO_SOCKET_DEFAULT ".\n",
            cmd, args, 0.25);
}

static const char *flag(json_t *a, const char *key, const char *name)
{
    return json_is_true(json_object_get(a, key)) ? name : NULL;
}

static void show_axes(json_t *rep)
{
    printf("%-8s %5s %11s  %-24s %s\n", "axis", "slave", "position", "status", "alarm");
    size_t i;
    json_t *a;
    json_array_foreach(json_object_get(rep, "axes"), i, a) {
        char status[64] = "";
        const char *names[] = {flag(a, "ready", "READY"), flag(a, "moving", "MOVE"),
                               flag(a, "in_pos", "IN-POS"), flag(a, "home_end", "HOME-END")};
        for (int k = 0; k < 4; k++)
            if (names[k])
                snprintf(status + strlen(status), sizeof status - strlen(status), "%s%s",
                         status[0] ? ", " : "", names[k]);
        json_int_t alarm = json_integer_value(json_object_get(a, "alarm"));
        char alarm_text[96] = "none";
        if (alarm)
            snprintf(alarm_text, sizeof alarm_text, "0x%02x %s", (unsigned)alarm,
                     json_string_value(json_object_get(a, "alarm_name")));
        printf("%-8s %5d %7.2f deg  %-24s %s\n", json_string_value(json_object_get(a, "axis")),
               (int)json_integer_value(json_object_get(a, "slave")),
               json_number_value(json_object_get(a, "position_deg")),
               status[0] ? status : "-", alarm_text);
    }
    json_t *lim = json_object_get(rep, "limits");
    if (lim)
        printf("limits %s: reached min %.2f deg, max %.2f deg, back at %.2f deg\n",
               json_string_value(json_object_get(lim, "axis")),
               json_number_value(json_object_get(lim, "reached_min_deg")),
               json_number_value(json_object_get(lim, "reached_max_deg")),
               json_number_value(json_object_get(lim, "back_at_deg")));
}

/* Options anywhere among the arguments; a negative DEG ("-30") is an
 * argument, which getopt would take for options. */
static int bringup(int argc, char **argv, const char *cmd, int min_args, int max_args)
{
    const char *sock = NULL, *args[2];
    int json = 0, n = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        char *end;
        if (!strcmp(a, "--socket") && i + 1 < argc) {
            sock = argv[++i];
        } else if (!strncmp(a, "--socket=", 9)) {
            sock = a + 9;
        } else if (!strcmp(a, "--json")) {
            json = 1;
        } else if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout, cmd);
            return 0;
        } else if (a[0] == '-' && (strtod(a, &end), end == a || *end)) {
            fprintf(stderr, "gonio %s: unknown option '%s'\n", cmd, a);
            usage(stderr, cmd);
            return 2;
        } else if (n < 2) {
            args[n++] = a;
        } else {
            n = 3;
        }
    }
    if (n < min_args || n > max_args) {
        fprintf(stderr, "gonio %s: %s\n", cmd,
                n < min_args ? "missing argument" : "unexpected argument");
        usage(stderr, cmd);
        return 2;
    }
    json_t *req = json_pack("{s:s}", "cmd", cmd);
    if (n >= 1)
        json_object_set_new(req, "axis", json_string(args[0]));
    if (n >= 2) {
        char *end;
        double deg = strtod(args[1], &end);
        if (end == args[1] || *end || !isfinite(deg)) {
            fprintf(stderr, "gonio move: DEG '%s' is not a number of degrees\n", args[1]);
            json_decref(req);
            return 2;
        }
        json_object_set_new(req, "deg", json_real(deg));
    }
    struct conn c;
    if (conn_open(&c, socket_path(sock)) < 0) {
        json_decref(req);
        return 1;
    }
    json_t *rep = conn_request(&c, req);
    int rc = reply_failed(rep);
    /* Aborted (gonio abort): exit 1, and where the axes stopped. */
    const char *code = rc ? json_string_value(json_object_get(rep, "code")) : NULL;
    int aborted = code && !strcmp(code, "aborted");
    if ((!rc || aborted) && json) {
        json_dumpf(rep, stdout, JSON_INDENT(2));
        putchar('\n');
    } else if (!rc || aborted) {
        show_axes(rep);
    }
    json_decref(rep);
    conn_close(&c);
    return rc;
}

int cmd_home(int argc, char **argv)
{
    return bringup(argc, argv, "home", 0, 1);
}

int cmd_move(int argc, char **argv)
{
    return bringup(argc, argv, "move", 2, 2);
}

int cmd_where(int argc, char **argv)
{
    return bringup(argc, argv, "where", 0, 0);
}

int cmd_limits(int argc, char **argv)
{
    return bringup(argc, argv, "limits", 1, 1);
}
