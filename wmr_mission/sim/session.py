"""A mission run step by step from Python: read the robot between steps, give
it a new path or target (docs/python-api.md, "A mission step by step").

The session is the runner's own run (wmr_mission.sim.runner), paused between
calls of the compiled loop: stepped to its end without changes it gives the
samples of ``run_mission``, and a new path set at a sample gives those of the
same update written in the mission (docs/mission-format.md, "References that
change on-line").
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import pydantic

from wmr_mission.output.result import RunResult
from wmr_mission.sim.plan import UpdatePlan, plan_mission, planned
from wmr_mission.sim.runner import NEVER, _Run
from wmr_mission.spec.checks import importing_entries
from wmr_mission.spec.loader import validate_mission
from wmr_mission.spec.models import Mission, Update
from wmr_mission.verdicts.metrics import judge_mission

__all__ = ["Session"]

_SET = "set from Python"


class Session:
    """A mission paused at a sample; ``step`` runs it on.

    Made by :func:`wmr_mission.api.start_mission`: the mission is checked as
    ``run_mission`` checks it and the loop is loaded (or compiled); the session
    waits at sample 0.
    """

    def __init__(self, mission: Mission, seed: int | None = None) -> None:
        with importing_entries():  # a run imports its plug-ins
            self._mission = validate_mission(mission)
        self._run = _Run(plan_mission(self._mission, seed), None, None)
        self._result: RunResult | None = None
        self._advance(0)

    # --- where the run is ---------------------------------------------------

    @property
    def sample(self) -> int:
        """The sample k the session waits at: samples 0 .. k-1 are done."""
        return int(self._run.signals.counters[0])

    @property
    def t(self) -> float:
        """[s] the time of the sample the session waits at."""
        return round(self.sample * self._run.m.dt, 9)

    @property
    def done(self) -> bool:
        """Whether the mission has ended (its result is ready)."""
        return self._result is not None

    @property
    def phase(self) -> str:
        """The name of the phase in force."""
        return self._run.active.phase.name

    @property
    def state(self) -> tuple[float, float, float]:
        """The true pose x, y, theta [m, m, rad] (simulated)."""
        x, y, theta = self._run.signals.state
        return float(x), float(y), float(theta)

    @property
    def estimate(self) -> tuple[float, float, float]:
        """The estimate x_{k|k} the controller acts on."""
        x, y, theta = self._run.signals.estimate
        return float(x), float(y), float(theta)

    @property
    def reference(self) -> tuple[float, float] | None:
        """The reference point in force at this sample: the path's point (track),
        the target's position (regulate, hold); None once done."""
        if self.done:
            return None
        active = self._run.active
        if active.tracks_a_path and active.phase.kind == "track":
            rows = active.path_ahead(self.sample - active.entry_sample, 1).rows
            return float(rows[0, 0]), float(rows[0, 1])
        return float(active.target[0]), float(active.target[1])

    # --- running ------------------------------------------------------------

    def step(self, samples: int = 1) -> bool:
        """Run ``samples`` samples (fewer if the mission ends); True while it goes on."""
        if isinstance(samples, bool) or not isinstance(samples, int) or samples < 0:
            raise ValueError(f"step takes a whole number of samples >= 0, got {samples!r}")
        return self._advance(self.sample + samples)

    def run_until(self, t: float) -> bool:
        """Run up to the sample of time ``t`` [s]; True while the mission goes on."""
        if not math.isfinite(t):
            raise ValueError(f"run_until takes a finite time, got {t!r}")
        return self._advance(max(self.sample, round(t / self._run.m.dt)))

    def set_path(self, path: Mapping[str, Any]) -> None:
        """A new path for the track phase in force, from this sample: any path
        of the mission format (``{"type": "line", ...}``), made from the estimated
        pose now and timed from now, as an update written in the mission is."""
        active = self._waiting("set_path", "track")
        update = planned(path, self._run.m.context, _SET)
        assert update.make_trajectory is not None
        # The path is made here: a path that cannot be made raises now, not in the loop.
        update.make_trajectory(self.estimate)
        self._run.advance(update)
        assert active is self._run.active

    def set_target(self, x: float, y: float, theta: float) -> None:
        """A new target pose for the regulate phase in force, from this sample."""
        self._waiting("set_target", "regulate")
        update = _checked(self._mission, {"target": {"x": x, "y": y, "theta": theta}})
        assert update.target is not None
        target = (float(update.target.x), float(update.target.y), float(update.target.theta))
        self._run.advance(UpdatePlan(when=_SET, target=target))

    def result(self) -> RunResult:
        """Run to the end and return the run, judged by the mission's ``expect``:
        the ``RunResult`` of ``run_mission`` (``result().write(DIR)`` for its run directory)."""
        self._advance(NEVER)
        assert self._result is not None
        return self._result

    # --- inside -------------------------------------------------------------

    def _waiting(self, what: str, kind: str) -> Any:
        if self.done:
            raise RuntimeError(f"{what}: the mission has ended")
        active = self._run.active
        if active.phase.kind != kind:
            raise ValueError(
                f"{what} applies to a {kind} phase; phase {active.phase.name!r} is a "
                f"{active.phase.kind} phase"
            )
        return active

    def _advance(self, pause_at: int) -> bool:
        if self._result is not None:
            return False
        self._run.pause_at = pause_at
        result = self._run.advance()
        if result is None:
            return True
        judge_mission(result, self._mission)  # as run_mission judges it
        self._result = result
        return False


def _checked(mission: Mission, change: dict[str, Any]) -> Update:
    """The change as an update of the mission's format, or ValueError saying what is wrong."""
    try:
        return Update.model_validate(
            {"when": {"elapsed": 1.0}, **change}, context={"regions": list(mission.regions)}
        )
    except pydantic.ValidationError as error:
        problems = "; ".join(
            f"{'.'.join(str(p) for p in e['loc'])}: {e['msg']}" for e in error.errors()
        )
        raise ValueError(f"not a valid {next(iter(change))}: {problems}") from None
