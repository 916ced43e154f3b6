"""How exact are the solutions of eq. (21) the regulator uses?

Runs case studies 1 and 2 (missions/case1.yaml, case2.yaml), replays the
linearisation point (theta, v, omega) of every regulation sample through
``wmr_mission.controllers.paper.scheduled_gain`` as the loop does (warm-started Newton
steps), and at every 25th sample compares three solutions of the same
body-frame problem with one computed to 40 digits (Newton's method in
mpmath, ``pip install mpmath``; not a dependency):

* the warm-started Newton solution the run used,
* the doubling from scratch (``wmr_mission.kernels.riccati.solve_riccati``),
* ``scipy.linalg.solve_discrete_are``.

It prints the largest relative error of the gain T of eq. (20) for each,
near rest (the solution at +-MIN_SPEED, |v| < 1 cm/s) and moving, and the
Newton steps per sample.

    python scripts/riccati_accuracy.py            # the figures in docs/paper-notes.md
"""

from __future__ import annotations

from pathlib import Path

import mpmath  # type: ignore[import-untyped]
import numpy as np
from scipy.linalg import solve_discrete_are

from wmr_mission.controllers import paper
from wmr_mission.kernels import riccati
from wmr_mission.kernels.model import jacobian_terms
from wmr_mission.kernels.records import scratch
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission

MISSIONS = Path(__file__).resolve().parent.parent / "missions"
EVERY = 25


def exact_gain(
    a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray, start: np.ndarray
) -> np.ndarray:
    """Eq. (20)-(21) by Newton's method in 40-digit arithmetic from ``start``."""
    mpmath.mp.dps = 40
    am, bm, qm = mpmath.matrix(a.tolist()), mpmath.matrix(b.tolist()), mpmath.matrix(q.tolist())
    rm = mpmath.diag([mpmath.mpf(float(r[0])), mpmath.mpf(float(r[1]))])
    pi = mpmath.matrix(start.tolist())
    for _ in range(40):
        gain = mpmath.inverse(rm + bm.T * pi * bm) * (bm.T * pi * am)
        f = am - bm * gain
        residual = qm + am.T * pi * f - pi
        # vec(X - F^T X F) = (I - F^T kron F^T) vec(X)
        ft = f.T
        system = mpmath.matrix(9, 9)
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    for m in range(3):
                        system[3 * i + j, 3 * k + m] = (i == k) * (j == m) - ft[i, k] * ft[j, m]
        correction = mpmath.lu_solve(
            system, mpmath.matrix([residual[i, j] for i in range(3) for j in range(3)])
        )
        pi += mpmath.matrix([[correction[3 * i + j] for j in range(3)] for i in range(3)])
        if max(abs(c) for c in correction) < mpmath.mpf(10) ** -35 * max(abs(p) for p in pi):
            break
    gain = mpmath.inverse(rm + bm.T * pi * bm) * (bm.T * pi * am)
    return np.array(gain.tolist(), dtype=float)


def gain_of(a: np.ndarray, b: np.ndarray, r: np.ndarray, pi: np.ndarray) -> np.ndarray:
    return np.linalg.solve(np.diag(r) + b.T @ pi @ b, b.T @ pi @ a)


def main() -> None:
    for name in ("case1", "case2"):
        mission = load_mission(MISSIONS / f"{name}.yaml")
        result = run_mission(mission)
        q = np.array(mission.controller.Q, dtype=float)
        r = np.array(mission.controller.R, dtype=float)
        dt = result.dt
        kinds = [p.kind for p in result.phases]
        samples = [k for k in range(1, result.samples) if kinds[result.phase[k]] != "track"]
        memory, work = np.zeros(paper.MEMORY_SIZE), scratch()
        worst = {"near rest": [0.0, 0.0, 0.0], "moving": [0.0, 0.0, 0.0]}
        steps = []
        doubled = 0
        for n, k in enumerate(samples):
            theta, v, omega = result.theta_est[k], result.v[k - 1], result.omega[k - 1]
            if result.phase[k] != result.phase[k - 1]:
                memory[:] = 0.0  # a new phase, as the runner does
            paper.scheduled_gain(theta, v, omega, dt, q, r, memory, work.gain)
            steps.append(memory[paper.NEWTON])
            doubled += memory[paper.DOUBLINGS] > 0
            if n % EVERY or v == 0.0:
                continue
            moving = abs(v) >= riccati.MIN_SPEED
            speed = v if moving else np.copysign(riccati.MIN_SPEED, v)
            slot = paper.WARM_MOVING if moving else paper.WARM_EDGE
            s = memory[slot + 1 : slot + 7]
            warm = np.array([[s[0], s[1], s[2]], [s[1], s[3], s[4]], [s[2], s[4], s[5]]])
            a13, a23, b11, b12, b21, b22 = jacobian_terms(0.0, speed, omega, dt)
            a = np.array([[1.0, 0.0, a13], [0.0, 1.0, a23], [0.0, 0.0, 1.0]])
            b = np.array([[b11, b12], [b21, b22], [0.0, dt]])
            c, sn = np.cos(theta), np.sin(theta)
            rot = np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])
            q_body = rot.T @ np.diag(q) @ rot
            g = b @ np.diag(1.0 / r) @ b.T
            doubling, _ = riccati.solve_riccati(
                riccati._mat3(a), riccati._mat3(g), riccati._mat3(q_body)
            )
            doubling = np.array(doubling).reshape(3, 3)
            scipy_pi = solve_discrete_are(a, b, q_body, np.diag(r))
            exact = exact_gain(a, b, q_body, r, doubling)
            regime = "moving" if abs(speed) >= 0.01 else "near rest"
            for i, pi in enumerate((warm, doubling, scipy_pi)):
                error = np.abs(gain_of(a, b, r, pi) - exact).max() / np.abs(exact).max()
                worst[regime][i] = max(worst[regime][i], error)
        counts = np.bincount(np.array(steps[1:], dtype=int))
        print(
            f"{name}: {len(samples)} regulation samples; "
            f"Newton steps per sample (0, 1, 2, ...): {counts.tolist()}; "
            f"solved by doubling: {doubled}"
        )
        for regime, (newton, doubling, scipy_error) in worst.items():
            print(
                f"  {regime}: largest relative gain error, warm-started Newton {newton:.1e}, "
                f"doubling {doubling:.1e}, scipy {scipy_error:.1e}"
            )


if __name__ == "__main__":
    main()
