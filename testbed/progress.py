"""Progress bars that stay readable in a log: `progress(...)` is tqdm on a terminal and, when
the stream is not a terminal (CI, batch logs, Ray workers, `2> file`), one plain line (ending
in a newline, no carriage returns) at most every OFF_TTY_INTERVAL_S seconds of wall time, plus
the final state when the bar is kept (leave=True).

Every progress bar of the testbed is made here; callers use the tqdm API (update, n = ...,
refresh, set_postfix_str, close). tqdm is imported on first use.
"""

from __future__ import annotations

import math
import sys
import time

OFF_TTY_INTERVAL_S = 10.0  # [s] of wall time between two progress lines off a terminal


def _is_terminal(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


class _LineStream:
    """Turns tqdm's carriage-return redraws into whole lines: each non-blank redraw is written
    as one line ending in a newline; blank ones (tqdm clearing the line) are dropped."""

    def __init__(self, stream):
        self.stream = stream

    def write(self, text: str) -> None:
        line = text.replace("\r", "").replace("\x1b[A", "").strip()
        if line:
            self.stream.write(line + "\n")

    def flush(self) -> None:
        getattr(self.stream, "flush", lambda: None)()


def progress(iterable=None, **kwargs):
    """A tqdm bar (same arguments). Off a terminal: lines at most every OFF_TTY_INTERVAL_S s."""
    from tqdm import tqdm

    class _Bar(tqdm):
        _min_gap_s = 0.0
        _last_line_s = -math.inf

        def refresh(self, *args, **kw):
            now = time.monotonic()
            if now - self._last_line_s < self._min_gap_s:
                return False
            self._last_line_s = now
            return super().refresh(*args, **kw)

    stream = kwargs.pop("file", None) or sys.stderr
    if _is_terminal(stream):
        return tqdm(iterable, file=stream, **kwargs)
    _Bar._min_gap_s = OFF_TTY_INTERVAL_S  # class attribute: set before tqdm's first refresh in __init__
    kwargs.update(file=_LineStream(stream), mininterval=OFF_TTY_INTERVAL_S, maxinterval=OFF_TTY_INTERVAL_S,
                  dynamic_ncols=False, ncols=100, ascii=True)
    return _Bar(iterable, **kwargs)
