"""`rpod run`'s progress on stderr: simulated time, real-time factor and time left.

Owns: `RunProgress`, the callback simulate() calls about twice a second of wall time while a
run goes on (rpod.diagrams.simulate), and the phase lines around it (building and the first
plan; writing the outputs).
Does not own: the run (simulate) or its one result line (cli.run_line).

On a terminal the line is redrawn in place and cleared at the end, so only the result line
stays. Elsewhere (a log file, CI, a test's captured stderr) nothing is written for a short run;
a run that goes on longer than `quiet_s` writes a plain line every `every_s`, so a log shows
that a long run is alive and where it is.
"""

import shutil
import sys
import time


class RunProgress:
    """Progress of one `rpod run` (see the module docstring)."""

    def __init__(self, name: str, stream=None, quiet_s: float = 10.0, every_s: float = 30.0):
        """Args:
        name: the scenario's name, at the start of each line.
        stream: where to write (stderr by default).
        quiet_s: off a terminal, nothing is written before this much wall time [s].
        every_s: off a terminal, the wall time between two lines [s].
        """
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.name = name
        self._quiet_s, self._every_s = quiet_s, every_s
        self._start = time.monotonic()
        self._last_line = self._start
        self._drawn = False

    def phase(self, text: str) -> None:
        """A phase with no simulated time to show (building and planning, writing)."""
        if self.tty:
            self._draw(f"rpod: {self.name}: {text} ...")

    def __call__(self, t_s: float, end_s: float) -> None:
        """simulate's progress callback: t_s of end_s simulated so far."""
        now = time.monotonic()
        wall = now - self._start
        if not self.tty and (wall < self._quiet_s or now - self._last_line < self._every_s):
            return
        self._last_line = now
        rate = t_s / wall if wall > 0 else 0.0
        left = (end_s - t_s) / rate if rate > 0 else float("nan")
        share = 100.0 * t_s / end_s if end_s > 0 else 100.0
        line = (
            f"rpod: {self.name}: {t_s:.0f}/{end_s:.0f} s simulated ({share:.0f} %), "
            f"{rate:.0f}x real time, ~{left:.0f} s left"
        )
        if self.tty:
            self._draw(line)
        else:
            self.stream.write(line + "\n")
            self.stream.flush()

    def done(self) -> None:
        """Clears the redrawn line (the result line follows)."""
        if self.tty and self._drawn:
            self.stream.write("\r\033[K")
            self.stream.flush()
            self._drawn = False

    def _draw(self, line: str) -> None:
        line = line[: max(20, shutil.get_terminal_size().columns - 1)]
        self.stream.write("\r" + line + "\033[K")
        self.stream.flush()
        self._drawn = True
