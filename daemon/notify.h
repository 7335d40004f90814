/* systemd's notification protocol (sd_notify(3)), without libsystemd: one
 * datagram of "KEY=VALUE" lines to the AF_UNIX socket named by
 * $NOTIFY_SOCKET. A name starting with '@' is in the abstract namespace.
 * Outside systemd (no $NOTIFY_SOCKET) every call is a no-op that succeeds. */
#ifndef GONIO_DAEMON_NOTIFY_H
#define GONIO_DAEMON_NOTIFY_H

/* Send one notification, e.g. notify_send("READY=1\nSTATUS=listening").
 * Returns 0 when sent or when there is no service manager, a negative errno
 * when the socket could not be reached. */
int notify_send(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* The watchdog interval asked for by the service manager (WatchdogSec=),
 * in microseconds, or 0 when none is set or $WATCHDOG_PID names another
 * process. The daemon pings every half of it. */
unsigned long long notify_watchdog_usec(void);

#endif
