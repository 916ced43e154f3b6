"""The metrics the verdicts judge by: zones in metres (verdicts/zones.py), tracking
against the timed reference (verdicts/tracking.py), the inputs' quality
(verdicts/inputs.py) and the `auto` thresholds (verdicts/metrics.py).

Each is checked against a reference worked out another way: a fine polygon
and scipy's k-d tree for distances, a brute-force search over every segment
for the place on the path, hand-made signals for the inputs.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from scipy.spatial import cKDTree
from test_output_synthetic import circle_run

from wmr_mission.record import Outcome
from wmr_mission.spec.loader import load_mission_text
from wmr_mission.spec.numbers import mission_numbers
from wmr_mission.verdicts import inputs
from wmr_mission.verdicts.metrics import check_expectations, judge, summarize
from wmr_mission.verdicts.regulation import stall_time
from wmr_mission.verdicts.tracking import place_on_path, track_quality, track_samples
from wmr_mission.verdicts.zones import Zone, intrusion_max

NUMBERS = mission_numbers(None, 0.01, (2.0, 3.0))  # tau 0.1 s, look-ahead 0.05 m, no noise


# --- zones ---------------------------------------------------------------------------


def _ellipse_reference(region: dict[str, Any], x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Signed distance from a 400 001-gon on the ellipse, by a k-d tree."""
    (cx, cy), (a, b), rotation = region["center"], region["semi_axes"], region["rotation"]
    c, s = math.cos(rotation), math.sin(rotation)
    angle = np.linspace(0.0, 2 * np.pi, 400_001)
    u, w = a * np.cos(angle), b * np.sin(angle)
    distance, _ = cKDTree(np.column_stack((cx + u * c - w * s, cy + u * s + w * c))).query(
        np.column_stack((x, y))
    )
    du, dw = (x - cx) * c + (y - cy) * s, -(x - cx) * s + (y - cy) * c
    return np.where((du / a) ** 2 + (dw / b) ** 2 <= 1, -distance, distance)


@pytest.mark.parametrize(
    ("semi_axes", "rotation"), [((5.5, 3.0), 0.3), ((1.0, 4.0), 1.0), ((3.0, 0.2), -0.5)]
)
def test_the_depth_of_an_ellipse_is_its_distance_in_metres(
    semi_axes: tuple[float, float], rotation: float
) -> None:
    region = {"type": "ellipse", "center": [1.0, -2.0], "semi_axes": list(semi_axes)}
    region["rotation"] = rotation
    rng = np.random.default_rng(0)
    size = max(semi_axes)
    x = 1.0 + np.r_[rng.uniform(-2, 2, 2000) * size, 0.0, 1e-9]
    y = -2.0 + np.r_[rng.uniform(-2, 2, 2000) * size, 0.0, 0.0]  # and the centre
    reference = _ellipse_reference(region, x, y)
    keep_in, keep_out = Zone("e", region, True), Zone("e", region, False)
    # the polygon's chords are within (2 pi size / 400 000)^2 / (8 radius) of the arc
    np.testing.assert_allclose(keep_in.depth(x, y), reference, atol=1e-6)
    np.testing.assert_allclose(keep_out.depth(x, y), -reference, atol=1e-6)
    # within 0.3 m: exact there and on the forbidden side, -inf only where surely farther
    near = keep_in.depth(x, y, within=0.3)
    known = np.isfinite(near)
    np.testing.assert_allclose(near[known], reference[known], atol=1e-6)
    assert np.all(reference[~known] < -0.3 + 1e-9)
    assert np.all(near[~known] == -np.inf)
    assert keep_in.deepest(x, y) == pytest.approx(reference.max(), abs=1e-6)
    assert keep_out.deepest(x, y) == pytest.approx(-reference.min(), abs=1e-6)
    np.testing.assert_array_equal(keep_out.beyond(x, y), -reference > 0)


def test_a_robot_held_on_an_ellipses_edge_is_on_it_to_a_micrometre() -> None:
    region = {"type": "ellipse", "center": [0.0, 0.0], "semi_axes": [5.5, 3.0], "rotation": 0.3}
    angle = np.linspace(0.0, 2 * np.pi, 1000)
    c, s = math.cos(0.3), math.sin(0.3)
    scale = 1.0 + 1e-8 * np.sin(7 * angle)  # a few nanometres either side of the edge
    u, w = 5.5 * scale * np.cos(angle), 3.0 * scale * np.sin(angle)
    x, y = u * c - w * s, u * s + w * c
    zone = Zone("e", region, True)
    assert abs(zone.deepest(x, y)) <= 1e-6
    assert zone.deepest(x, y) >= float(np.max(zone.depth(x, y)))


def test_the_depth_of_the_other_regions_by_hand() -> None:
    box = Zone("b", {"type": "box", "min": [0.0, 0.0], "max": [4.0, 2.0]}, True)
    x, y = np.array([1.0, 5.0, 5.0, 3.9]), np.array([1.0, 1.0, 3.0, 1.8])
    np.testing.assert_allclose(box.depth(x, y), [-1.0, 1.0, math.sqrt(2), -0.1])
    square = [[0.0, 0.0], [4.0, 0.0], [4.0, 2.0], [0.0, 2.0]]
    for vertices in (square, square[::-1]):  # either orientation
        polygon = Zone("p", {"type": "polygon", "vertices": vertices}, True)
        np.testing.assert_allclose(polygon.depth(x, y), box.depth(x, y))
    circle = Zone("c", {"type": "circle", "center": [1.0, 1.0], "radius": 0.5}, False)
    expected = [0.5, -3.5, -(math.hypot(4, 2) - 0.5), -(math.hypot(2.9, 0.8) - 0.5)]
    np.testing.assert_allclose(circle.depth(x, y), expected)
    fence = Zone("f", {"type": "half-plane", "normal": [3.0, 4.0], "offset": 5.0}, True)
    np.testing.assert_allclose(fence.depth(np.array([3.0]), np.array([4.0])), [4.0])


def test_a_phase_that_starts_in_a_zone_may_leave_it_in_time() -> None:
    """5 cm inside a keep-out circle at the start: leaving within the least time
    the limits need is no intrusion; staying longer is, from the start."""
    pond = Zone("pond", {"type": "circle", "center": [0.0, 0.0], "radius": 1.0}, False)
    allowed = NUMBERS.recovery_time(0.05, 0.0)  # 0.025 + pi/3 + 0.5 = 1.57 s
    for seconds, expected in ((allowed - 0.1, 0.0), (allowed + 0.1, 0.05)):
        samples = round(seconds / NUMBERS.dt)
        x = np.r_[np.full(samples, 0.95), np.linspace(1.0, 2.0, 100)]
        assert intrusion_max(x, np.zeros(x.size), [pond], NUMBERS) == pytest.approx(expected)
    # later, any sample inside counts
    x = np.r_[np.linspace(2.0, 1.02, 50), np.full(10, 0.993), np.linspace(1.02, 2.0, 50)]
    assert intrusion_max(x, np.zeros(x.size), [pond], NUMBERS) == pytest.approx(0.007)
    assert intrusion_max(x, np.zeros(x.size), [], NUMBERS) is None


# --- the place on the path ------------------------------------------------------------


def _brute_force(
    px: np.ndarray, py: np.ndarray, rx: np.ndarray, ry: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Every segment tried; of those within 1 cm of the nearest, the nearest in arc
    length to the sample's own reference point."""
    sx, sy = np.diff(rx), np.diff(ry)
    length = np.hypot(sx, sy)
    arc = np.r_[0.0, np.cumsum(length)]
    cross, lag = np.empty(px.size), np.empty(px.size)
    for k in range(px.size):
        along = ((px[k] - rx[:-1]) * sx + (py[k] - ry[:-1]) * sy) / length**2
        along = np.clip(along, 0, 1)
        distance = np.hypot(px[k] - rx[:-1] - along * sx, py[k] - ry[:-1] - along * sy)
        at = arc[:-1] + along * length
        near = distance <= distance.min() + 0.01
        best = int(np.argmin(np.where(near, np.abs(at - arc[k]), np.inf)))
        cross[k], lag[k] = distance[best], arc[k] - at[best]
    return cross, lag


def test_the_place_on_the_path_is_the_nearest_one_near_the_reference() -> None:
    """Round a circle three times, 0.3 rad behind the reference and 5 cm outside
    it with 2 cm of noise; then a spiral at a varying speed."""
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 14.0, 0.01)
    angle = 2.0 * t
    rx, ry = 2 * np.cos(angle), 2 * np.sin(angle)
    px = 2.05 * np.cos(angle - 0.3) + rng.normal(0, 0.02, t.size)
    py = 2.05 * np.sin(angle - 0.3) + rng.normal(0, 0.02, t.size)
    cross, lag = place_on_path(px, py, rx, ry, near=0.12, first=100)
    expected_cross, expected_lag = _brute_force(px, py, rx, ry)
    assert np.isnan(cross[:100]).all()
    assert np.isnan(lag[:100]).all()
    # equal but where two places are within the 1 cm the brute force calls equal
    np.testing.assert_allclose(cross[100:], expected_cross[100:], atol=0.01)
    np.testing.assert_allclose(lag[100:], expected_lag[100:], atol=0.06)
    assert np.median(lag[100:]) == pytest.approx(2.05 * 0.3, abs=0.02)
    s = np.cumsum(np.abs(np.sin(t)) * 0.02)
    rx, ry = s * np.cos(s), s * np.sin(s)
    px, py = rx + rng.normal(0, 0.03, t.size), ry + rng.normal(0, 0.03, t.size)
    cross, lag = place_on_path(px, py, rx, ry, near=0.13)
    expected_cross, expected_lag = _brute_force(px, py, rx, ry)
    np.testing.assert_allclose(cross, expected_cross, atol=0.01)
    np.testing.assert_allclose(lag, expected_lag, atol=0.06)


def test_a_robot_stalled_on_its_path_is_on_it_and_behind() -> None:
    t = np.arange(0.0, 14.0, 0.01)
    x = np.minimum(t, 3.9)
    cross, lag = place_on_path(x, np.zeros(t.size), t, np.zeros(t.size), near=0.1)
    assert np.abs(cross).max() == 0.0
    np.testing.assert_allclose(lag, np.maximum(t - 3.9, 0.0), atol=1e-12)
    # a reference that stands still before and after it moves
    rx = np.r_[np.zeros(50), np.linspace(0.0, 5.0, 500), np.full(50, 5.0)]
    cross, lag = place_on_path(rx - 0.05, np.full(rx.size, 0.02), rx, np.zeros(rx.size), 0.1)
    np.testing.assert_allclose(cross[60:-60], 0.02, atol=1e-12)
    np.testing.assert_allclose(lag[60:-60], 0.05, atol=1e-12)


def _detour_run(depth: float, stop: float | None = None) -> dict[str, Any]:
    """A 14 s line at 1 m/s past a keep-out circle of radius 1 at (5, 0.7),
    the robot on a raised-cosine bump ``depth`` below the line round it, or
    stopped at x = ``stop``."""
    t = np.arange(0.0, 14.0 + 0.005, 0.01)
    x = t.copy() if stop is None else np.minimum(t, stop)
    y = np.where(np.abs(x - 5) < 2.5, -depth * (1 + np.cos(np.pi * (x - 5) / 2.5)) / 2, 0.0)
    rock = Zone("rock", {"type": "circle", "center": [5.0, 0.7], "radius": 1.0}, False)
    return track_quality(t, x, y, t.copy(), np.zeros(t.size), NUMBERS, [rock])


def test_a_detour_round_a_zone_is_measured_as_one() -> None:
    quality = _detour_run(0.4)
    # judged again once the robot has kept up with its reference for 5 tau (0.5 s):
    # within the tolerance (0.1 m) of it, their velocities apart by at most
    # 0.1 m / 5 tau (the bump's slope): on the bump's last 8 mm (its first 4 cm
    # come before the path is within the time a detour needs to start of the
    # zone: 0.1 mm off)
    t = np.arange(0.0, 14.0 + 0.005, 0.01)
    y = np.where(np.abs(t - 5) < 2.5, -0.4 * (1 + np.cos(np.pi * (t - 5) / 2.5)) / 2, 0.0)
    slope = np.where(
        np.abs(t - 5) < 2.5, 0.4 * np.pi / 5 * np.abs(np.sin(np.pi * (t - 5) / 2.5)), 0
    )
    with_it = (np.abs(y) <= 0.1) & (slope <= 0.1 / 0.5)
    rock = Zone("rock", {"type": "circle", "center": [5.0, 0.7], "radius": 1.0}, False)
    _, placed = track_samples(t, t.copy(), y, t.copy(), np.zeros(t.size), NUMBERS, [rock])
    assert placed is not None
    after = int(np.flatnonzero(placed.detour)[-1]) + 1
    back = after + int(np.flatnonzero(with_it[after:])[0])  # with it from here on ...
    rejoined = back + 50 - 1  # ... for 5 tau: 50 samples
    judged = int(np.flatnonzero(placed.judged[after:])[0]) + after
    assert abs(judged - rejoined) <= 1
    assert quality["cross_track_error_max"] == pytest.approx(abs(y[judged]), abs=1e-9)
    assert quality["cross_track_error_max"] < 0.01
    assert quality["along_track_lag_max"] < 1e-9
    assert quality["detour_offset_max"] == pytest.approx(0.4, abs=1e-3)
    assert 3.0 < quality["detour_time"] < 6.0
    assert quality["zone_reach"] == pytest.approx(0.3)
    # on its reference from the first sample: the entry left out ends once the
    # robot has kept up for 5 tau (50 samples), well before its allowance
    # (pi / 3 + 0.5 s)
    assert quality["entry_time"] == pytest.approx(0.49)
    assert quality["reference_speed_max"] == pytest.approx(1.0)


def test_a_robot_that_stops_at_a_zone_is_not_detouring() -> None:
    quality = _detour_run(0.0, stop=3.9)
    assert quality["along_track_lag_max"] == pytest.approx(14.0 - 3.9, abs=0.01)
    assert quality["cross_track_error_max"] < 1e-9


def test_a_timed_phase_that_ends_in_its_entry_is_judged_at_its_end() -> None:
    """A line 5 m ahead at 1.98 m/s against a 2 m/s limit: the limits need 25 s to
    join it; a 5 s phase that runs for its time is judged at its last sample."""
    t = np.arange(0.0, 5.0 + 0.005, 0.01)
    x = 2.0 * t
    numbers = mission_numbers(None, 0.01, (2.0, 3.0))
    rx = 5.0 + 1.98 * t
    timed = track_quality(t, x, np.zeros(t.size), rx, np.zeros(t.size), numbers, [], True)
    assert timed["entry_time"] > 25.0
    assert timed["along_track_lag_max"] == pytest.approx(rx[-1] - x[-1])
    ended_on_a_goal = track_quality(t, x, np.zeros(t.size), rx, np.zeros(t.size), numbers, [])
    assert ended_on_a_goal["along_track_lag_max"] is None


# --- the inputs -----------------------------------------------------------------------


def test_reversals_are_counted_in_any_window_beyond_the_floor() -> None:
    k = np.arange(300)
    t = k * 0.01
    u = np.where((k // 20) % 2 == 0, 1.0, -1.0)  # a reversal every 0.2 s
    assert inputs.most_reversals(t, u, 0.05, 1.0) == 5
    assert inputs.most_reversals(t, 0.01 * u, 0.05, 1.0) == 0  # within the floor
    slow = np.where(k < 150, 1.0, -1.0)
    assert inputs.most_reversals(t, slow, 0.05, 1.0) == 1
    # a dip through the floor and back to the same sign is no reversal
    dip = np.where(np.abs(k - 100) < 10, 0.01, 1.0)
    assert inputs.most_reversals(t, dip, 0.05, 1.0) == 0


def test_a_fight_at_the_limit_against_a_deliberate_drive() -> None:
    v = np.r_[np.zeros(10), np.full(50, 2.0), np.zeros(10)]  # 0.5 s at the limit, one way
    assert inputs.fight_time(v, 2.0, NUMBERS, lambda a, b: True) == 0.0
    assert inputs.fight_time(v, 2.0, NUMBERS, lambda a, b: False) == pytest.approx(0.5)
    both_ways = np.r_[np.full(30, 2.0), np.full(30, -2.0)]
    assert inputs.fight_time(both_ways, 2.0, NUMBERS, lambda a, b: True) == pytest.approx(0.6)
    brief = np.r_[np.zeros(5), np.full(9, 2.0), np.zeros(5)]  # shorter than a time constant
    assert inputs.fight_time(brief, 2.0, NUMBERS, lambda a, b: False) == 0.0


def test_a_drive_counts_as_deliberate_when_half_of_it_is_progress() -> None:
    t = np.arange(0.0, 2.0, 0.01)
    v = np.full(t.size, 2.0)
    straight = inputs.progress_to(2.0 * t, np.zeros(t.size), (10.0, 0.0))
    assert inputs.input_quality(t, v, 0 * t, NUMBERS, straight)["speed_fight_time"] == 0.0
    circling = inputs.progress_to(np.cos(t), np.sin(t), (10.0, 0.0))
    fought = inputs.input_quality(t, v, 0 * t, NUMBERS, circling)["speed_fight_time"]
    assert fought == pytest.approx(2.0)


def test_a_reversal_to_the_limit_is_judged_by_the_motion_it_makes_after_the_plants_lag() -> None:
    """A park entered at +1 m/s with its target behind: the speed goes to -2
    m/s, its limit, for 0.17 s, but a plant with a 30 ms input delay and a 50
    ms actuator lag rolls on forwards first. Read at the same samples, the
    progress was a third of the distance driven at the limit, a fight (the
    shipped disturbed mission failed so, 0.17 s). The motion a command makes
    is read the delay and the lag later: a deliberate drive. A robot that
    makes no progress at all still fights, lag or not."""
    dt, delay, lag = 0.01, 0.03, 0.05
    v = np.r_[np.full(5, 1.0), np.full(17, -2.0), np.linspace(-1.9, 0.0, 28)]
    t = np.arange(v.size) * dt
    moved, x = 1.0, [0.0]  # the plant: the command delayed, then a first-order lag
    for k in range(1, v.size):
        moved += dt / lag * (v[max(k - 1 - round(delay / dt), 0)] - moved)
        x.append(x[-1] + moved * dt)
    towards = inputs.progress_to(np.array(x), np.zeros(v.size), (-2.0, 0.0))
    assert towards(5, 22) < 0.5 * 2.0 * 17 * dt  # at the same samples: under half
    now = inputs.input_quality(t, v, 0 * t, NUMBERS, towards)["speed_fight_time"]
    assert now == pytest.approx(0.17)
    lagged = NUMBERS._replace(response=delay + lag)
    assert inputs.input_quality(t, v, 0 * t, lagged, towards)["speed_fight_time"] == 0.0
    stuck = inputs.progress_to(np.zeros(v.size), np.zeros(v.size), (-2.0, 0.0))
    fought = inputs.input_quality(t, v, 0 * t, lagged, stuck)["speed_fight_time"]
    assert fought == pytest.approx(0.17)
    # read no later than the next update or the phase's end: the motion after
    # either is not the stretch's (an update at its end: judged as without lag)
    cut = inputs.input_quality(t, v, 0 * t, lagged, towards, cuts=[22])["speed_fight_time"]
    assert cut == now
    ending = slice(0, 23)  # the phase ends at the stretch's end: judged as without lag
    short = inputs.progress_to(np.array(x[ending]), np.zeros(23), (-2.0, 0.0))
    for numbers in (NUMBERS, lagged):
        made = inputs.input_quality(t[ending], v[ending], 0 * t[ending], numbers, short)
        assert made["speed_fight_time"] == pytest.approx(0.17)


def test_turn_rate_jitter_of_known_signals() -> None:
    k = np.arange(400)
    window = 2 * 10 + 1  # two time constants of 0.1 s at dt 0.01
    # +-a about a constant: the mean over an odd window keeps a/window of it
    alternating = 0.5 + 2.0 * (-1.0) ** k
    expected = 1.4826 * 2.0 * (1 - 1 / window)
    assert inputs.jitter(alternating, NUMBERS) == pytest.approx(expected)
    assert inputs.jitter(0.01 * k, NUMBERS) == pytest.approx(0.0, abs=1e-12)  # a ramp
    burst = np.full(400, 0.5)
    burst[200:230] += 3.0 * (-1.0) ** np.arange(30)  # a manoeuvre's few samples
    assert inputs.jitter(burst, NUMBERS) == pytest.approx(0.0, abs=1e-12)
    assert inputs.jitter(np.ones(120), NUMBERS) is None  # 1 s skipped, then too short


def test_turn_rate_jitter_counts_the_samples_it_is_given() -> None:
    """A track phase's jitter counts the samples its tracking is judged at: the
    steps of an entry or a detour, each off the moving mean for two time
    constants, filled half of a short phase and set its median."""
    k = np.arange(300)
    quiet = 0.02 * (-1.0) ** k  # 0.02 rad/s of chatter about zero
    steps = quiet.copy()
    for start in range(100, 240, 30):  # turns of 2 rad/s for 0.15 s, 0.3 s apart
        steps[start : start + 15] += 2.0
    manoeuvre = (k >= 90) & (k < 260)
    expected = inputs.jitter(quiet, NUMBERS)
    assert expected == pytest.approx(1.4826 * 0.02 * (1 - 1 / 21))
    assert inputs.jitter(steps, NUMBERS) > 10 * expected  # the steps set the median
    assert inputs.jitter(steps, NUMBERS, ~manoeuvre) == pytest.approx(expected)
    deviation = inputs.jitter_deviation(steps, NUMBERS, ~manoeuvre)
    assert np.isnan(deviation[manoeuvre]).all()
    assert np.isfinite(deviation[260:290]).all()
    # none counted (a phase all entry): all are, as without the mask
    none = np.zeros(300, dtype=bool)
    assert inputs.jitter(steps, NUMBERS, none) == inputs.jitter(steps, NUMBERS)


def test_inputs_are_judged_from_the_estimates_first_convergence() -> None:
    t = np.arange(0.0, 1.0, 0.01)
    decay = 0.9 ** np.arange(t.size)
    errors = {"x": decay, "y": decay, "theta": np.zeros(t.size)}
    # (2 * 0.9^(2k))^0.5 <= 0.05 first at k = 32
    assert inputs.first_judged(t, errors, NUMBERS) == pytest.approx(0.32)
    noisy = mission_numbers({"sensors": {"noise_std": {"x": 0.01, "y": 0.01}}}, 0.01, (2, 3))
    # 0.08 m each way: 0.9^k <= 0.08 / 2^0.5 first at k = 28
    assert inputs.first_judged(t, errors, noisy) == pytest.approx(0.28)
    assert inputs.first_judged(t, {**errors, "theta": np.ones(t.size)}, NUMBERS) is None


# --- regulation -----------------------------------------------------------------------


def test_a_regulator_is_judged_by_its_progress_to_its_target() -> None:
    """A window is 2.05 s here (half a turn at 3 rad/s and ten time constants,
    more than 20 time constants): each must take out 10 % of the error."""
    t = np.arange(0.0, 10.0, 0.01)
    zero = np.zeros(t.size)
    goal = (0.05, 0.05)
    steady = 4.0 * np.exp(-t / 2.0)  # 4 m out, the error halving every 1.4 s
    assert stall_time(steady, zero, zero, (0.0, 0.0, 0.0), goal, NUMBERS) == 0.0
    # stops 1.5 m short at 2.5 s, facing 0.5 rad off (either error would do): a
    # window from t takes out 2.5 - t m, less than 10 % of 4 - t from t = 2.34 s,
    # and the last window starts 2.05 s before the end
    short = np.maximum(4.0 - t, 1.5)
    off = np.full(t.size, 0.5)
    stalled = stall_time(short, zero, off, (0.0, 0.0, 0.0), goal, NUMBERS)
    assert stalled == pytest.approx(7.94 - 2.34 + 0.01, abs=0.015)
    # at the target it may rest; turning in place towards the heading is progress
    turning = np.maximum(1.0 - t, 0.0)
    assert stall_time(zero, zero, turning, (0.0, 0.0, 0.0), goal, NUMBERS) == 0.0
    # a limit cycle in place, 3 mm either way
    shaking = 0.5 + 0.003 * (-1.0) ** np.arange(t.size)
    assert stall_time(shaking, zero, off, (0.0, 0.0, 0.0), goal, NUMBERS) == pytest.approx(7.95)
    # a target beyond a keep-out zone: the robot stops as near as it allows
    rock = Zone("rock", {"type": "circle", "center": [0.0, 0.0], "radius": 1.0}, False)
    assert stall_time(short, zero, off, (0.0, 0.0, 0.0), goal, NUMBERS, [rock]) is None


# --- the thresholds -------------------------------------------------------------------


MISSION = """
version: 1
name: t
robot: {dt: 0.01, limits: {v: 2, omega: 3}}
sensors: {noise_std: {x: 0.02, y: 0.01, theta: 0.03}}
controller: {tracking: {time_constant: 0.2}}
phases:
  - name: approach
    track: {path: {type: circle, center: [0, 0], radius: 2, angular_rate: 0.5}}
    until: {elapsed: 5}
  - name: orbit
    track: {path: {type: circle, center: [0, 0], radius: 2, angular_rate: 0.5}}
    until: {elapsed: 10}
    expect: {turn_rate_jitter: {max: 0.9}, along_track_lag_max: auto}
  - name: park
    regulate: {target: {x: 0, y: 0, theta: 0}}
    until: {elapsed: 5}
expect:
  along_track_lag_max: null
"""


def test_auto_thresholds_come_from_the_missions_numbers() -> None:
    mission = load_mission_text(MISSION, "t.yaml").model_dump(mode="json")
    assert mission["expect"]["turn_rate_jitter"] == "auto"
    run = circle_run()
    checks = check_expectations(summarize(run, mission), mission)
    bound = {(c.phase, c.metric): c.bound for c in checks}
    tolerance = 0.1 + 0.02  # the larger position noise std
    assert bound["approach", "cross_track_error_max"] == pytest.approx(tolerance)
    # null mission-wide, auto in the orbit: the reference's 1 m/s for 3 time constants
    assert ("approach", "along_track_lag_max") not in bound
    assert bound["orbit", "along_track_lag_max"] == pytest.approx(tolerance + 3 * 0.2 * 1.0)
    assert bound["approach", "turn_rate_jitter"] == pytest.approx(0.01 * 3 + 0.03 / 0.2)
    assert bound["orbit", "turn_rate_jitter"] == 0.9
    assert bound["park", "speed_jump_max"] == 2.0
    assert bound["park", "turn_rate_jump_max"] == 3.0
    assert bound["park", "turn_rate_reversals"] == 3
    assert bound["park", "speed_fight_time"] == 0.0
    # the park keeps inside its ellipse; no detour without a zone on a track phase;
    # tracking only on track phases
    assert bound["park", "zone_intrusion_max"] == 0.005
    assert not any(m == "detour_offset_max" for _, m in bound)
    assert ("park", "cross_track_error_max") not in bound


def test_a_run_that_kicks_its_turn_rate_is_not_a_success() -> None:
    mission = load_mission_text(MISSION, "t.yaml").model_dump(mode="json")
    run = circle_run()
    run.omega = run.omega.copy()
    run.omega[1700] = -3.0  # from 0.5 to -3 and back: 3.5 rad/s in one sample
    judge(run, mission)
    assert run.outcome is Outcome.expect_failed
    # the synthetic park circles 2 m round its target: 1.6 m past it along the way in
    assert run.message == (
        "expectation not met: park: overshoot_max = 1.60229 (max 0.12); "
        "park: turn_rate_jump_max = 3.5 (max 3)"
    )
