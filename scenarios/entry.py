"""The `rpod` console script's entry point: a Ctrl-C is one line from the first instant.

`rpod.scenarios.cli` imports pydrake and numpy at its top, 1-3 s before its `main` and the
handlers in it exist; a Ctrl-C meanwhile printed Python's KeyboardInterrupt traceback (40-50
lines of import machinery), or, when it landed inside a compiled module's initialisation,
pybind11's `ImportError: initialization failed` with the KeyboardInterrupt as its cause.

So this module imports nothing but what the interpreter has already loaded (os, signal, sys),
and while it imports the command line a Ctrl-C does not raise at all: the handler says
`rpod: interrupted` on stderr and ends the process at once with exit status 130 (nothing has
been written yet, so there is nothing to clean up). A SIGINT that the parent set to be ignored
(a background job of a non-interactive shell) stays ignored. Once the command line is loaded
Python's own handler is back, and `cli.main` turns a KeyboardInterrupt into the same line and
status, cleaning up what a run started; one it does not catch (raised while the arguments are
parsed, or an interrupted import inside a command) ends here the same way. A process
stopped inside an import ends without the interpreter's finalisation (`_end_now`).
Does not own: the command line (cli.py), which `python -m rpod.scenarios.cli` still runs.
"""

import os
import signal
import sys

EXIT_INTERRUPTED = 128 + signal.SIGINT  # 130, as a shell reports a Ctrl-C
MESSAGE = "rpod: interrupted"


def _interrupted_while_loading(signum, frame) -> None:
    os.write(sys.stderr.fileno(), f"{MESSAGE}\n".encode())
    os._exit(EXIT_INTERRUPTED)


def _an_interrupt(error: BaseException) -> bool:
    """True when error is a KeyboardInterrupt, or was raised because of one (pybind11 turns a
    KeyboardInterrupt during a compiled module's initialisation into an ImportError, and
    Python 3.11 one inside a class's `__set_name__`, matplotlib's at import, into a
    RuntimeError)."""
    seen = set()
    while error is not None and id(error) not in seen:
        if isinstance(error, KeyboardInterrupt):
            return True
        seen.add(id(error))
        error = error.__cause__ or error.__context__
    return False


# BLAS thread pools off unless the user set them (as the campaign's runners do, harness.py):
# rpod's matrices are small, so a pool only adds synchronisation, and on a loaded machine it
# stalls (measured on 2 busy cores: a 120 x 246 x 120 product, paper 004's condensed MPC, took
# 0.19 ms on one OpenBLAS thread and 36 ms on two). Set before numpy is first imported.
BLAS_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def main(argv=None) -> int:
    """Entry point of the `rpod` console script (pyproject.toml, [project.scripts])."""
    for name in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(name, "1")
    loading = signal.getsignal(signal.SIGINT) is signal.default_int_handler
    if loading:
        signal.signal(signal.SIGINT, _interrupted_while_loading)
    try:
        from rpod.scenarios.cli import main as cli_main
    finally:
        if loading:
            signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        status = cli_main(argv)
    except (KeyboardInterrupt, Exception) as error:  # an interrupt, or one wrapped by an import
        if not _an_interrupt(error):
            raise
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C must not cut this line
        print(f"rpod: {getattr(error, 'message', 'interrupted')}", file=sys.stderr)
        _end_now(getattr(error, "exit_status", EXIT_INTERRUPTED))
    from rpod.scenarios import cli

    if cli.interrupted_in_an_import:
        _end_now(status)
    return status


def _end_now(status: int) -> None:
    """Ends the process without the interpreter's finalisation. A Ctrl-C inside a compiled
    module's import (pydrake's, which a command imports at use) leaves that module half made,
    and finalising it once aborted the interpreter after the one line ("Fatal Python error:
    PyThreadState_Get", CI under load). What the command started it has cleaned up by now."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


if __name__ == "__main__":
    sys.exit(main())
