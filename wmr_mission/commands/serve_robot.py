"""``wmr-mission serve-robot MISSION``: the mission's plant and sensors as a
ROS 2 robot, for ``run --backend ros2`` without a robot (docs/backends.md)."""

from __future__ import annotations

import sys
from pathlib import Path

from wmr_mission.commands.run import EXIT_FAILED, EXIT_UNREADABLE, STOP_SIGNALS


def serve_robot_command(
    mission_path: Path, *, seed: int | None, plan_from: Path | None = None
) -> int:
    """Exit code: 1 invalid mission or ROS 2 missing; 130 or 143 when stopped
    by SIGINT or SIGTERM, its way of ending. ``plan_from``: a mission whose
    updates on time are published as plans (wmr_mission.backends.robot.ScriptedPlans)."""
    from wmr_mission.backends import BackendError
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.spec.loader import check_mission_bytes, read_source, unreadable
    from wmr_mission.stopping import StopSignals

    with StopSignals(STOP_SIGNALS) as stop:
        try:
            missions = []
            for path in (mission_path, plan_from):
                if path is None:
                    continue
                source, diagnostics = read_source(path)
                checked = None
                if source is not None:
                    checked, diagnostics = check_mission_bytes(source, str(path), [])
                for diagnostic in diagnostics:
                    print(diagnostic, file=sys.stderr)
                if source is None and unreadable(diagnostics):
                    return EXIT_UNREADABLE
                if checked is None:
                    return EXIT_FAILED
                missions.append(checked)
            from wmr_mission.backends.robot import serve

            mission = missions[0]
            planner = missions[1] if plan_from is not None else None
            serve(plan_mission(mission, seed), mission.backend, planner)
        except BackendError as error:
            print(f"{mission_path}: {error}", file=sys.stderr)
            return EXIT_FAILED
        except KeyboardInterrupt:
            print(f"serve-robot: stopped by {stop.name}", file=sys.stderr)
            return stop.exit_code
    return 0
