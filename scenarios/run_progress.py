"""`rpod run`'s progress on stderr: simulated time, real-time factor and time left.

Owns: `RunProgress`, the callback simulate() calls about twice a second of wall time while a
run goes on (rpod.diagrams.simulate), and the phase lines around it (building and the first
plan; writing the outputs), and `bar_size`, the terminal size both bars are drawn in.
Does not own: the run (simulate) or its one result line (cli.run_line).

On a terminal, a run that lasts more than `bar_after_s` of wall time gets a progress bar (tqdm:
simulated seconds, real-time factor, time left), redrawn in place and cleared at the end, so
only the result line stays; the phases are one line redrawn in the same place. Elsewhere (a
log file, CI, a test's captured stderr) nothing is written for a short run; a run that goes on
longer than `quiet_s` writes a plain line every `every_s`, so a log shows that a long run is
alive and where it is.
"""

import shutil
import sys
import time

from tqdm import tqdm

_BAR_FORMAT = (
    "{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} s simulated{postfix} "
    "[{elapsed}<{remaining}]"  # tqdm puts ", " before the postfix (the real-time factor)
)


class RunProgress:
    """Progress of one `rpod run` (see the module docstring)."""

    def __init__(
        self,
        name: str,
        stream=None,
        quiet_s: float = 10.0,
        every_s: float = 30.0,
        bar_after_s: float = 2.0,
    ):
        """Args:
        name: the scenario's name, at the start of each line.
        stream: where to write (stderr by default).
        quiet_s: off a terminal, nothing is written before this much wall time [s].
        every_s: off a terminal, the wall time between two lines [s].
        bar_after_s: on a terminal, the bar shows once the run has lasted this long [s].
        """
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.name = name
        self._quiet_s, self._every_s = quiet_s, every_s
        self._start = time.monotonic()
        self._last_line = self._start
        self._drawn = False
        self._bar_after_s = bar_after_s
        self._bar = None

    def phase(self, text: str) -> None:
        """A phase with no simulated time to show (building and planning, writing)."""
        if self.tty:
            self._close_bar()
            self._draw(f"rpod: {self.name}: {text} ...")

    def __call__(self, t_s: float, end_s: float) -> None:
        """simulate's progress callback: t_s of end_s simulated so far."""
        now = time.monotonic()
        wall = now - self._start
        if not self.tty and (wall < self._quiet_s or now - self._last_line < self._every_s):
            return
        self._last_line = now
        rate = t_s / wall if wall > 0 else 0.0
        if self.tty:
            self._update_bar(t_s, end_s, rate, wall)
            return
        left = (end_s - t_s) / rate if rate > 0 else float("nan")
        share = 100.0 * t_s / end_s if end_s > 0 else 100.0
        self.stream.write(
            f"rpod: {self.name}: {t_s:.0f}/{end_s:.0f} s simulated ({share:.0f} %), "
            f"{rate:.0f}x real time, ~{left:.0f} s left\n"
        )
        self.stream.flush()

    def _update_bar(self, t_s: float, end_s: float, rate: float, wall: float) -> None:
        if self._bar is None:
            if wall < self._bar_after_s:
                return
            if self._drawn:  # the phase line gives way to the bar
                self.stream.write("\r\033[K")
                self._drawn = False
            self._bar = tqdm(
                total=end_s,
                desc=f"rpod: {self.name}",
                file=self.stream,
                leave=False,
                **bar_size(),
                bar_format=_BAR_FORMAT,
                initial=min(t_s, end_s),
                postfix=f"{rate:.0f}x real time",
            )
        self._bar.n = min(t_s, end_s)
        self._bar.set_postfix_str(f"{rate:.0f}x real time", refresh=False)
        self._bar.refresh()

    def _close_bar(self) -> None:
        if self._bar is not None:
            self._bar.close()  # leave=False: the bar's line is cleared
            self._bar = None

    def done(self) -> None:
        """Clears the bar or the redrawn line (the result line follows)."""
        self._close_bar()
        if self.tty and self._drawn:
            self.stream.write("\r\033[K")
            self.stream.flush()
            self._drawn = False

    def _draw(self, line: str) -> None:
        line = line[: max(20, shutil.get_terminal_size().columns - 1)]
        self.stream.write("\r" + line + "\033[K")
        self.stream.flush()
        self._drawn = True


def bar_size() -> dict:
    """tqdm's ncols and nrows (for `rpod run`'s bar and the sweep's): the terminal's, the line
    one short (so that "\\r" redraws it); 80 x 24 for a terminal that states no size (a
    pseudo-terminal of 0 x 0, where tqdm would draw nothing)."""
    columns, lines = shutil.get_terminal_size()
    return {"ncols": (columns if columns > 1 else 80) - 1, "nrows": lines if lines > 1 else 24}
