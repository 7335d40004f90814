/* SIGINT and SIGTERM for gonio's offline work (capture --offline, study):
 * the signal only sets a flag, the job asks for it at its next record
 * boundary and ends there cleanly (the journal whole, no temporary file),
 * and the command says how to resume and exits 130. */
#ifndef GONIO_CLI_INTERRUPT_H
#define GONIO_CLI_INTERRUPT_H

/* Catch SIGINT and SIGTERM from now on. */
void interrupt_catch(void);

/* The signal caught (SIGINT, SIGTERM), 0 when none. */
int interrupt_signal(void);

/* Forget the signal caught: the next interrupt_signal says whether
 * another came since (a second Ctrl-C). */
void interrupt_reset(void);

/* The exit status of a command a signal ended: 128 + SIGINT, as a shell
 * reports an interrupted command. */
#define INTERRUPT_EXIT 130

#endif
