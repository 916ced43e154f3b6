"""The EKF's +-3 std band of the estimation figure: its covariance replayed
from the run's columns (wmr_mission/output/covariance.py)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

from wmr_mission import load_mission, run_mission
from wmr_mission.output.covariance import estimate_std
from wmr_mission.output.figures import plot_estimation_error
from wmr_mission.output.result import RunResult

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def noisy_ekf() -> RunResult:
    return run_mission(load_mission(ROOT / "missions" / "noisy-ekf.yaml"))


def test_the_replay_follows_the_whole_run_and_settles_at_the_riccati_solution(
    noisy_ekf: RunResult,
) -> None:
    std = estimate_std(noisy_ekf)
    assert std is not None
    assert std.shape == (noisy_ekf.samples, 3)
    assert np.isfinite(std).all()  # the replayed estimate is the recorded one throughout
    np.testing.assert_allclose(std[0], [0.5, 0.5, 0.3])  # the mission's initial_std
    # At rest (the `stop` phase: v ~ 0, so A ~ I) the heading's variance is the
    # steady state of the discrete Riccati equation: X the prediction's, P the
    # update's. (The positions' process noise follows the noise and the look-ahead,
    # 4.5e-6 m: their filter's time constant, sqrt(r / q) = 4400 samples, is
    # longer than the run.)
    process = load_mission(ROOT / "missions" / "noisy-ekf.yaml").estimator.model_dump()
    q = np.diag([process["process_std"][s] for s in ("x", "y", "theta")]) ** 2
    r = np.diag([0.02, 0.02, 0.02]) ** 2
    x = scipy.linalg.solve_discrete_are(np.eye(3), np.eye(3), q, r)
    p = x - x @ np.linalg.solve(x + r, x)
    np.testing.assert_allclose(std[-1, 2], np.sqrt(p[2, 2]), rtol=1e-6)
    assert (std[-1, :2] < 0.2 * 0.02).all()  # a fifth of the noise, and falling
    # and it is an honest band: the true error stays inside 3 std after the start
    error = np.abs(np.column_stack([noisy_ekf.x - noisy_ekf.x_est, noisy_ekf.y - noisy_ekf.y_est]))
    assert (error[1:] < 3.0 * std[1:, :2]).mean() > 0.99


def test_the_band_stops_where_the_record_is_another_run(noisy_ekf: RunResult) -> None:
    x_est = noisy_ekf.x_est.copy()
    x_est[1000] += 0.01  # an estimate the filter did not make
    std = estimate_std(dataclasses.replace(noisy_ekf, x_est=x_est))
    assert std is not None
    assert np.isfinite(std[:1000]).all()
    assert np.isnan(std[1000:]).all()


def test_only_the_ekf_has_a_band_and_the_figure_draws_it(noisy_ekf: RunResult) -> None:
    observer = run_mission(load_mission(ROOT / "missions" / "noisy-observer.yaml"))
    assert estimate_std(observer) is None
    figure = plot_estimation_error(noisy_ekf)
    labels = {h.get_label() for ax in figure.axes for h in ax.collections}
    assert "EKF +-3 std (its covariance)" in labels
    assert "+-3 std" in figure.get_suptitle()
    assert "+-3 std" not in plot_estimation_error(observer).get_suptitle()


DISTURBED_SENSORS = """
version: 1
name: ekf-sensors
robot:
  dt: 0.01
  initial_state: {x: 0, y: 0, theta: 0}
  limits: {v: 2, omega: 3}
sensors:
  measure: [x, y]
  noise_std: {x: 0.01, y: 0.01}
  period: 0.05
  dropout: {probability: 0.1, burst: 3}
  outliers: {probability: 0.05, std: {x: 0.5, y: 0.5, theta: 0}}
  seed: 7
estimator:
  type: ekf
  innovation_gate: 16.27
  measurement_std: {x: 0.02, y: 0.02}
  # the heading's random walk written (the default takes none with the
  # heading unmeasured): the band of a state that grows between measurements
  process_std: {x: 2.25e-6, y: 2.25e-6, theta: 0.001}
phases:
  - name: line
    track: {path: {type: line, heading: 0.3, speed: 1}}
    until: {elapsed: 8}
expect: {turn_rate_jitter: null}
"""


def test_the_replay_holds_with_slow_lost_and_wild_measurements_and_read_back(
    tmp_path: Path,
) -> None:
    """Between measurements, through lost bursts, gated outliers and an
    unmeasured heading the replay is the filter's, live and read back from
    the run's files (12 significant digits)."""
    from wmr_mission.api import load_run, mission_from_text

    result = run_mission(mission_from_text(DISTURBED_SENSORS))
    assert np.isnan(result.x_meas).sum() > 0.8 * result.samples  # one sample in five, less losses
    std = estimate_std(result)
    assert std is not None
    assert np.isfinite(std).all()
    assert std[:, 2].max() > std[-1, 0]  # the heading, unmeasured, is the least certain
    result.write(tmp_path / "run", plots=False)
    again = estimate_std(load_run(tmp_path / "run"))
    assert again is not None
    assert np.isfinite(again).all()
    np.testing.assert_allclose(again, std, rtol=1e-8)
