"""A job's progress on a terminal: one bar redrawn in place (`\\r`) on a TTY; on anything else (a log, a pipe)
a plain line per stage and per tenth, so a log is not flooded with carriage returns."""

from __future__ import annotations

from typing import TextIO

from iwr_client.client import Progress

BAR_WIDTH = 24


def format_eta(seconds: float) -> str:
    """'ETA 7 s', 'ETA 2 min 05 s', 'ETA 1 h 02 min'."""
    whole = max(0, round(seconds))
    if whole < 60:
        return f"ETA {whole} s"
    if whole < 3600:
        return f"ETA {whole // 60} min {whole % 60:02d} s"
    return f"ETA {whole // 3600} h {whole % 3600 // 60:02d} min"


def format_progress(progress: Progress, width: int = BAR_WIDTH) -> str:
    """`identifying [##########..............]  42% iteration 7, ETA 3 s`."""
    fraction = min(1.0, max(0.0, progress.fraction))
    filled = int(fraction * width)
    text = f"{progress.stage:<11} [{'#' * filled}{'.' * (width - filled)}] {fraction:4.0%}"
    details = []
    if progress.iteration is not None:
        details.append(f"iteration {progress.iteration}")
    if progress.eta_seconds is not None:
        details.append(format_eta(progress.eta_seconds))
    return text + (" " + ", ".join(details) if details else "")


class ProgressBar:
    """The `on_progress` callback of `Client.wait`: draws on `stream` (stderr in the CLI); `close` ends the line."""

    def __init__(self, stream: TextIO, *, tty: bool | None = None) -> None:
        self.stream = stream
        self.tty = stream.isatty() if tty is None else tty
        self._drawn = 0  # the width of the line on screen, to blank what a shorter redraw leaves
        self._last_line: tuple[str, int] | None = None

    def __call__(self, progress: Progress) -> None:
        text = format_progress(progress)
        if self.tty:
            self.stream.write("\r" + text.ljust(self._drawn))
            self._drawn = len(text)
        else:
            key = (progress.stage, int(min(1.0, max(0.0, progress.fraction)) * 10))
            if key == self._last_line:
                return
            self._last_line = key
            self.stream.write(text + "\n")
        self.stream.flush()

    def close(self) -> None:
        if self.tty and self._drawn:
            self.stream.write("\n")
            self.stream.flush()
            self._drawn = 0
