/* The gonio subcommands. Each takes argv with argv[0] = its own name and
 * returns the process exit status: 0, 1 for a failure, 2 for bad input. */
#ifndef GONIO_CLI_COMMANDS_H
#define GONIO_CLI_COMMANDS_H

int cmd_plan(int argc, char **argv);
int cmd_capture(int argc, char **argv);
int cmd_export(int argc, char **argv);
int cmd_results(int argc, char **argv);

#endif
