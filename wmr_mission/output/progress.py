"""Progress on a terminal, drawn by rich: a command's steps, a line each.

Shown only where the stream is a terminal: a log or a pipe gets none of it.
Redrawn when the command reports something (at most :data:`REDRAWS_PER_SECOND`
times a second), never from a thread of its own: a campaign forks its worker
processes while it shows, and a fork copies no other thread.
"""

from __future__ import annotations

import time
from contextlib import ExitStack
from typing import IO, TYPE_CHECKING, Any

from wmr_mission.output.report import WIDTH

if TYPE_CHECKING:
    from rich.progress import Progress, TaskID

__all__ = ["Steps"]

REDRAWS_PER_SECOND = 10


class Steps:
    """The steps of a command on ``stream``: each a line with its name, a bar
    (a count of ``total``, or moving while the step lasts), a detail and the
    time it took. Finished steps stay on the screen above the current one."""

    def __init__(self, stream: IO[str] | None) -> None:
        self._stream = stream
        self._progress: Progress | None = None
        self._task: TaskID | None = None
        self._drawn = 0.0
        self._compiles_said = ExitStack()
        if stream is None or not stream.isatty():
            return
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        # The stream itself: the command line's shows control codes escaped (wmr_mission.cli).
        console = Console(file=getattr(stream, "raw", stream), highlight=False)
        console.width = min(console.width, WIDTH)
        self._progress = Progress(
            TextColumn("{task.description}", markup=False),
            BarColumn(bar_width=30),
            TextColumn("{task.fields[detail]}", markup=False),
            TimeElapsedColumn(),
            console=console,
            auto_refresh=False,
            redirect_stdout=False,
            redirect_stderr=False,
        )
        self._progress.start()
        # A compile's line (wmr_mission.kernels.jit.compiling_notice) printed
        # above the steps while they are drawn: a bare line would be drawn over.
        from wmr_mission.kernels import jit

        self._compiles_said.enter_context(jit.compiles_said_by(self.say))

    def step(self, name: str, total: int | None = None) -> None:
        """End the current step and start ``name``: a count up to ``total``,
        or without one, a step that lasts. Shown at once."""
        if self._progress is None:
            return
        self._finish()
        self._task = self._progress.add_task(name, total=total, detail="")
        self._draw()

    def update(self, completed: float, detail: str = "", description: str | None = None) -> None:
        """The current step's count (and its detail, or its name); shown when
        the last redraw is a tenth of a second old."""
        if self._progress is None or self._task is None:
            return
        fields: dict[str, Any] = {"detail": detail}
        if description is not None:
            fields["description"] = description
        self._progress.update(self._task, completed=completed, **fields)
        if time.monotonic() - self._drawn >= 1.0 / REDRAWS_PER_SECOND:
            self._draw()

    def say(self, line: str) -> None:
        """Print ``line`` above the steps at once (on a terminal only)."""
        if self._progress is None:
            return
        self._progress.console.print(line, markup=False)
        self._draw()

    def note(self, line: str) -> None:
        """Print ``line`` above the steps, or on the stream where it is no
        terminal (a log keeps it)."""
        if self._progress is not None:
            self.say(line)
        elif self._stream is not None:
            print(line, file=self._stream, flush=True)

    def close(self) -> None:
        """End the current step; the lines stay, the cursor below them."""
        if self._progress is None:
            return
        self._finish()
        self._progress.stop()
        self._progress = None
        self._compiles_said.close()

    def _finish(self) -> None:
        assert self._progress is not None
        if self._task is not None:
            task = self._progress.tasks[-1]
            if task.total is None:  # a step that lasted: its bar full
                self._progress.update(self._task, total=1, completed=1)
            self._progress.stop_task(self._task)
            self._task = None

    def _draw(self) -> None:
        assert self._progress is not None
        self._progress.refresh()
        self._drawn = time.monotonic()
