"""How a campaign's runs needed their reactions: campaign.json's ``recovery``.

Each run succeeds without a reaction, succeeds after one (a retry, a
contingency, ... : summary.json's ``success-after-recovery``), or fails.
The rates carry 95 % Clopper-Pearson intervals, as ``success_rate`` does.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from wmr_mission.campaign.rows import Row

__all__ = ["RecoveryCounts", "recovery_report"]


Interval = Callable[[int, int], tuple[float, float]]


def _rate(count: int, runs: int, interval: Interval) -> dict[str, Any]:
    lo, hi = interval(count, runs)
    return {"count": count, "rate": count / runs if runs else None, "interval": [lo, hi]}


@dataclass
class RecoveryCounts:
    runs: int = 0
    without: int = 0  # succeeded with no reaction
    after: int = 0  # succeeded after a reaction
    needed: int = 0  # runs in which a reaction fired
    fired: Counter[str] = field(default_factory=Counter)  # kind -> times fired
    fired_runs: Counter[str] = field(default_factory=Counter)  # kind -> runs it fired in

    def add(self, row: Row) -> None:
        self.runs += 1
        needed = bool(row.fired)
        self.needed += needed
        if row.succeeded:
            self.without += not needed
            self.after += needed
        self.fired.update(row.fired)
        self.fired_runs.update(set(row.fired))

    def statistics(self, interval: Interval) -> dict[str, Any]:
        """``success_without_recovery`` and ``success_after_recovery`` (of all
        runs), ``recovery_rate`` (successes among the runs that needed a
        reaction), ``needed`` (runs with a reaction), and ``fired``: per
        reaction (a contingency's name, retry, goto, next, fail) the
        times it fired and the runs it fired in. ``interval(successes, trials)``
        is the campaign's (Clopper-Pearson)."""
        return {
            "success_without_recovery": _rate(self.without, self.runs, interval),
            "success_after_recovery": _rate(self.after, self.runs, interval),
            "needed": self.needed,
            "recovery_rate": _rate(self.after, self.needed, interval),
            "fired": {
                kind: {"times": self.fired[kind], "runs": self.fired_runs[kind]}
                for kind in sorted(self.fired)
            },
        }


def recovery_report(statistics: dict[str, Any]) -> str:
    """The lines of the sweep's report on recoveries."""
    after = statistics["success_after_recovery"]
    without = statistics["success_without_recovery"]
    rate = statistics["recovery_rate"]
    lo, hi = rate["interval"]
    fired = ", ".join(
        f"{kind} {counts['times']}x in {counts['runs']} runs"
        for kind, counts in statistics["fired"].items()
    )
    return "\n".join(
        [
            f"recovery: {statistics['needed']} runs needed a reaction, {after['count']} of them "
            f"succeeded (recovery rate {rate['rate']:.2%}, 95 % interval {lo:.2%} .. {hi:.2%})",
            f"success without recovery {without['count']}, after recovery {after['count']}",
            f"reactions fired: {fired}",
        ]
    )
