"""Plug-ins for tests/test_plugins.py: controllers and an estimator written
as a mission's ``type: python`` entries name them (``plugin_examples:NAME``)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import float64, int64
from numba.experimental import jitclass

# --- a controller: Kanayama's law with its own gains, as plain Python and compiled


class Kanayama:
    """Along a path, Kanayama's law; to a pose, drive to it and turn."""

    def __init__(self, k_x: float, k_y: float, k_theta: float) -> None:
        self.k_x = k_x
        self.k_y = k_y
        self.k_theta = k_theta
        self.steps = 0

    def step(self, t: float, estimate: Any, reference: Any) -> tuple[float, float]:
        self.steps += 1
        c = math.cos(estimate[2])
        s = math.sin(estimate[2])
        dx = reference.x - estimate[0]
        dy = reference.y - estimate[1]
        e_x = c * dx + s * dy
        e_y = -s * dx + c * dy
        e_theta = math.atan2(
            math.sin(reference.theta - estimate[2]), math.cos(reference.theta - estimate[2])
        )
        if not reference.tracking:
            return 0.5 * e_x, 2.0 * e_y + 0.5 * e_theta
        return (
            reference.v * math.cos(e_theta) + self.k_x * e_x,
            reference.omega + reference.v * (self.k_y * e_y + self.k_theta * math.sin(e_theta)),
        )


CompiledKanayama = jitclass(
    [("k_x", float64), ("k_y", float64), ("k_theta", float64), ("steps", int64)]
)(Kanayama)

SEEN: list[tuple[float, tuple[float, ...], tuple[Any, ...]]] = []


class Watched(Kanayama):
    """Kanayama, keeping what each step was given."""

    def step(self, t: float, estimate: Any, reference: Any) -> tuple[float, float]:
        SEEN.append((t, tuple(estimate), tuple(reference[:6])))
        return super().step(t, estimate, reference)


def plain(params: dict[str, float], setup: Any) -> Kanayama:
    return Kanayama(params["x"], params["y"], params["theta"])


def compiled(params: dict[str, float], setup: Any) -> Any:
    return CompiledKanayama(params["x"], params["y"], params["theta"])


def watched(params: dict[str, float], setup: Any) -> Watched:
    SEEN.clear()
    return Watched(params["x"], params["y"], params["theta"])


# --- controllers that fail


class Three:
    def step(self, t: float, estimate: Any, reference: Any) -> tuple[float, float, float]:
        return (0.1, 0.0, 1.0)


def three_numbers(params: dict[str, Any], setup: Any) -> Three:
    return Three()


class GivesUp:
    def step(self, t: float, estimate: Any, reference: Any) -> tuple[float, float]:
        if t >= 0.25:
            raise RuntimeError("no idea where to go")
        return (0.2, 0.0)


def gives_up(params: dict[str, Any], setup: Any) -> GivesUp:
    return GivesUp()


@jitclass([("limit", float64)])
class CompiledGivesUp:
    def __init__(self, limit: float) -> None:
        self.limit = limit

    def step(self, t: float, estimate: Any, reference: Any) -> tuple[float, float]:
        if t >= self.limit:
            raise RuntimeError("no idea where to go")
        return (0.2, 0.0)


def compiled_gives_up(params: dict[str, Any], setup: Any) -> Any:
    return CompiledGivesUp(0.25)


class Steps:
    """(0.2, 0) until t = 0.25 s, then what ``then(t)`` gives (or raises)."""

    def __init__(self, then: Any) -> None:
        self.then = then

    def step(self, t: float, estimate: Any, reference: Any) -> Any:
        return (0.2, 0.0) if t < 0.25 else self.then(t)


def infinite(params: dict[str, Any], setup: Any) -> Steps:
    return Steps(lambda t: (0.5, math.inf))


def text(params: dict[str, Any], setup: Any) -> Steps:
    return Steps(lambda t: ("1", "0"))


class WrongSignature:
    def step(self, t: float) -> tuple[float, float]:  # not (t, estimate, reference)
        return (0.0, 0.0)


def wrong_signature(params: dict[str, Any], setup: Any) -> WrongSignature:
    return WrongSignature()


def one_number(params: dict[str, Any], setup: Any) -> Steps:
    return Steps(lambda t: 0.5)


def nothing(params: dict[str, Any], setup: Any) -> Steps:
    return Steps(lambda t: None)


def out_of_memory(params: dict[str, Any], setup: Any) -> Steps:
    def no_memory(t: float) -> Any:
        raise MemoryError("the plug-in's map did not fit")

    return Steps(no_memory)


def refuses(params: dict[str, Any], setup: Any) -> Any:
    raise ValueError(f"params need a 'gain', got {sorted(params)}")


NOT_CALLABLE = 3

# --- an estimator: eq. (1) predicted, each measured state drawn to the measurement

CALLS: list[tuple[bool, tuple[float, float]]] = []


class Blend:
    def __init__(self, blend: float, dt: float, start: tuple[float, float, float]) -> None:
        self.blend = blend
        self.dt = dt
        self.x = np.array(start, dtype=np.float64)

    def step(self, measurement: Any, applied: Any) -> Any:
        CALLS.append((measurement is not None, (float(applied[0]), float(applied[1]))))
        x, y, theta = self.x
        v, omega = applied
        h = 0.5 * self.dt * self.dt * v * omega
        x, y, theta = (
            x + self.dt * v * math.cos(theta) - h * math.sin(theta),
            y + self.dt * v * math.sin(theta) + h * math.cos(theta),
            theta + self.dt * omega,
        )
        if measurement is not None:
            x += self.blend * (measurement[0] - x)
            y += self.blend * (measurement[1] - y)
            theta += self.blend * math.atan2(
                math.sin(measurement[2] - theta), math.cos(measurement[2] - theta)
            )
        self.x[:] = (x, y, theta)
        return self.x


def blend(params: dict[str, float], setup: Any) -> Blend:
    CALLS.clear()
    return Blend(params["blend"], setup.dt, setup.initial_estimate)


class Drawn:
    """The same estimator without the record of its calls: plain and compiled."""

    def __init__(self, blend: float, dt: float, x: Any) -> None:
        self.blend = blend
        self.dt = dt
        self.x = x

    def step(self, measurement: Any, applied: Any) -> tuple[float, float, float]:
        x, y, theta = self.x[0], self.x[1], self.x[2]
        v, omega = applied[0], applied[1]
        h = 0.5 * self.dt * self.dt * v * omega
        x, y, theta = (
            x + self.dt * v * math.cos(theta) - h * math.sin(theta),
            y + self.dt * v * math.sin(theta) + h * math.cos(theta),
            theta + self.dt * omega,
        )
        if measurement is not None:
            x += self.blend * (measurement[0] - x)
            y += self.blend * (measurement[1] - y)
            theta += self.blend * math.atan2(
                math.sin(measurement[2] - theta), math.cos(measurement[2] - theta)
            )
        self.x[0], self.x[1], self.x[2] = x, y, theta
        return x, y, theta


CompiledDrawn = jitclass([("blend", float64), ("dt", float64), ("x", float64[:])])(Drawn)


def drawn(params: dict[str, float], setup: Any) -> Drawn:
    return Drawn(params["blend"], setup.dt, np.array(setup.initial_estimate))


def compiled_drawn(params: dict[str, float], setup: Any) -> Any:
    return CompiledDrawn(params["blend"], setup.dt, np.array(setup.initial_estimate))


class TextEstimate(Drawn):
    def step(self, measurement: Any, applied: Any) -> Any:
        x, y, theta = super().step(measurement, applied)
        return (str(x), str(y), str(theta))


def text_estimate(params: dict[str, float], setup: Any) -> TextEstimate:
    return TextEstimate(params["blend"], setup.dt, np.array(setup.initial_estimate))


class ColumnEstimate(Drawn):
    """A column of three, [[x], [y], [theta]], not three numbers."""

    def step(self, measurement: Any, applied: Any) -> Any:
        return [[value] for value in super().step(measurement, applied)]


def column_estimate(params: dict[str, float], setup: Any) -> ColumnEstimate:
    return ColumnEstimate(params["blend"], setup.dt, np.array(setup.initial_estimate))


class LostEstimate(Drawn):
    """Its estimate's x ``lost`` (not a number, or a terametre off) from t = 0.25 s on."""

    def __init__(self, blend: float, dt: float, x: Any, lost: float) -> None:
        super().__init__(blend, dt, x)
        self.lost, self.steps = lost, 0

    def step(self, measurement: Any, applied: Any) -> Any:
        x, y, theta = super().step(measurement, applied)
        self.steps += 1
        return (self.lost, y, theta) if self.steps > 25 else (x, y, theta)


def lost_estimate(params: dict[str, float], setup: Any) -> LostEstimate:
    lost = float(params["lost"])
    return LostEstimate(params["blend"], setup.dt, np.array(setup.initial_estimate), lost)
