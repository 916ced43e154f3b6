"""The result a run hands to its caller: the run's record (``wmr_mission.record``)
with the ways to write it, as ``summary.json`` and as a run directory."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from wmr_mission.output import rundir
from wmr_mission.record import RunRecord

__all__ = ["RunResult"]


class RunResult(RunRecord):
    """A run's record (every sample as arrays, each transition and phase), and
    its ``summary()`` and ``write()``."""

    def summary(self) -> dict[str, Any]:
        """Every metric of the run: exactly what ``summary.json`` holds."""
        return rundir.summary_record(self)

    def write(
        self,
        out_dir: str | os.PathLike[str],
        *,
        plots: bool = True,
        animate: bool = False,
        formats: tuple[str, ...] = ("png",),
    ) -> Path:
        """Write a run directory, as ``wmr-mission run --out`` does; return its path.

        The directory must be new or empty (a run never overwrites another).
        """
        directory = rundir.prepare_run_dir(out_dir)
        rundir.write_run(
            self, directory, mission_file=None, plots=plots, animate=animate, formats=formats
        )
        return directory
