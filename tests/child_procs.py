"""Child processes that die with their test: a goniod or gonio-sim a Python
test starts gets SIGKILL when the test process dies (PR_SET_PDEATHSIG), so a
test that crashes or hits its ctest TIMEOUT leaves no daemon behind holding a
port, a lock or ctest's output pipe (tests/gonio_test.h, gonio_test_fork, for
the C tests).

    subprocess.Popen(argv, preexec_fn=child_procs.die_with_parent)
    pid, fd = pty.fork(); if pid == 0: child_procs.die_with_parent(); os.execv(...)

The signal comes when the thread that started the child ends: start children
from the test's main thread."""
import ctypes
import os
import signal

PR_SET_PDEATHSIG = 1
_PARENT = os.getpid()
_libc = ctypes.CDLL(None, use_errno=True)


def die_with_parent():
    """In the child, before exec: ask for SIGKILL when the test dies, and
    exit at once if it already has."""
    if _libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) != 0 or os.getppid() != _PARENT:
        os._exit(127)
