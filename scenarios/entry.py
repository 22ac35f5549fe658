"""The `rpod` console script's entry point: a Ctrl-C is one line from the first instant.

`rpod.scenarios.cli` imports pydrake and numpy at its top, 1-3 s before its `main` and the
handlers in it exist; a Ctrl-C meanwhile printed Python's KeyboardInterrupt traceback (40-50
lines of import machinery). This module imports nothing but the standard library's `signal`
and `sys` (already loaded by the interpreter) and imports the command line inside `main`, so a
KeyboardInterrupt raised while it loads, or anywhere `cli.main` does not catch one (parsing
the arguments), ends as `cli.main` ends one: `rpod: interrupted` on stderr, exit status 130.
Does not own: the command line (cli.py), which `python -m rpod.scenarios.cli` still runs.
"""

import signal
import sys

EXIT_INTERRUPTED = 128 + signal.SIGINT  # 130, as a shell reports a Ctrl-C


def main(argv=None) -> int:
    """Entry point of the `rpod` console script (pyproject.toml, [project.scripts])."""
    try:
        from rpod.scenarios.cli import main as cli_main

        return cli_main(argv)
    except KeyboardInterrupt as interrupt:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C must not cut this line
        print(f"rpod: {getattr(interrupt, 'message', 'interrupted')}", file=sys.stderr)
        return getattr(interrupt, "exit_status", EXIT_INTERRUPTED)


if __name__ == "__main__":
    sys.exit(main())
