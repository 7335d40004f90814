/* The gonio subcommands. Each takes argv with argv[0] = its own name and
 * returns the process exit status: 0, 1 for a failure, 2 for bad input. */
#ifndef GONIO_CLI_COMMANDS_H
#define GONIO_CLI_COMMANDS_H

int cmd_plan(int argc, char **argv);
int cmd_capture(int argc, char **argv);
int cmd_export(int argc, char **argv);
int cmd_fit(int argc, char **argv);
int cmd_results(int argc, char **argv);
int cmd_train_decoder(int argc, char **argv);
int cmd_report(int argc, char **argv);
int cmd_plot(int argc, char **argv);
int cmd_render(int argc, char **argv);
int cmd_study(int argc, char **argv);
int cmd_journal(int argc, char **argv);
int cmd_live(int argc, char **argv);
int cmd_calibrate(int argc, char **argv);
int cmd_recalibrate(int argc, char **argv);
/* gonio calibrate's request (a calibrate document, stolen) run on goniod
 * at sock (NULL: the default): its exit status. */
struct json_t;
int cmd_calibrate_goniod(struct json_t *req, const char *sock);

/* cmd_daemon.c: the commands that talk to goniod. cmd_capture_any runs
 * cmd_capture for --offline and cmd_capture_daemon otherwise. */
int cmd_capture_any(int argc, char **argv);
int cmd_capture_daemon(int argc, char **argv);
int cmd_status(int argc, char **argv);
int cmd_watch(int argc, char **argv);
int cmd_pause(int argc, char **argv);
int cmd_resume(int argc, char **argv);
int cmd_abort(int argc, char **argv);
int cmd_shutdown(int argc, char **argv);
/* cmd_bringup.c: bring-up of a new rig through goniod. */
int cmd_home(int argc, char **argv);
int cmd_move(int argc, char **argv);
int cmd_where(int argc, char **argv);
int cmd_limits(int argc, char **argv);
int cmd_list(int argc, char **argv);

/* --budget MINUTES, --stop-target LOG_ERR (opt) of both capture commands:
 * a positive number, else a message on stderr and -1. */
int cmd_capture_number(const char *opt, const char *text, double *out);

/* --prescan N (both captures): the count as given (0..CAPTURE_PRESCAN_MAX)
 * and as capture_config.prescan; prints the error and returns -1 on a bad
 * one. PRESCAN_HELP: its --help lines, before each command's default. */
int cmd_capture_prescan(const char *text, long long *points, int *prescan);
#define PRESCAN_STR_(x) #x
#define PRESCAN_STR(x) PRESCAN_STR_(x)
#define PRESCAN_HELP                                                                         \
    "  --prescan N: first measure N of the plan's points (0: none, at most "                 \
    PRESCAN_STR(CAPTURE_PRESCAN_MAX) "), spread\n"                                              \
    "  over its order, so that the ETA counts the integration the detector chooses\n"        \
    "  for an unknown material from early on; they are ordinary samples, which the\n"        \
    "  plan's order then skips\n"

#endif
