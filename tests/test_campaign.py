"""Campaign runs: determinism per (seed, run), identical rows on any number of
workers or a Dask cluster, replay of a run, Ctrl-C, statistics."""

from __future__ import annotations

import csv
import io
import json
import math
import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import the_tests_package

from wmr_mission import run_campaign
from wmr_mission.campaign.aggregate import clopper_pearson
from wmr_mission.campaign.engine import LAST_TASK_SECONDS, task_size, tasks
from wmr_mission.campaign.load import load_campaign
from wmr_mission.campaign.plan import Draw, Plan
from wmr_mission.campaign.rows import INVALID, mission_of
from wmr_mission.campaign.sweep import sweep_command
from wmr_mission.kernels import jit
from wmr_mission.stopping import StopSignals

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "campaigns"
EVERY = DATA / "valid" / "every_distribution.yaml"


def _campaign(tmp_path: Path, runs: int, seed: int = 11, name: str = "c.yaml") -> Path:
    path = tmp_path / name
    path.write_text(
        f"""version: 1
name: headings
mission: {DATA / "short.yaml"}
runs: {runs}
seed: {seed}
vary:
  robot.initial_state.theta: {{uniform: [-3.0, 3.0]}}
  estimator.initial_estimate.y: {{normal: [0.5, 0.2]}}
  sensors.noise_std.x: {{choice: [0.0, 0.01]}}
""",
        encoding="utf-8",
    )
    return path


def test_run_draws_from_the_spawned_child_of_its_index(tmp_path: Path) -> None:
    plan = Plan(load_campaign(_campaign(tmp_path, 20)).campaign)
    children = np.random.SeedSequence(11).spawn(20)
    for run in (0, 7, 19):
        rng = np.random.default_rng(children[run])
        seed = int(rng.integers(2**32, dtype=np.uint64))
        theta = float(rng.uniform(-3.0, 3.0))
        y = float(rng.normal(0.5, 0.2))
        noise = [0.0, 0.01][int(rng.integers(2))]
        expected = Draw(run, seed, {
            "robot.initial_state.theta": theta,
            "estimator.initial_estimate.y": y,
            "sensors.noise_std.x": noise,
        })  # fmt: skip
        assert plan.draw(run) == expected


def test_draws_do_not_depend_on_the_number_of_runs(tmp_path: Path) -> None:
    small = Plan(load_campaign(_campaign(tmp_path, 5, name="a.yaml")).campaign)
    large = Plan(load_campaign(_campaign(tmp_path, 500, name="b.yaml")).campaign)
    assert [small.draw(i) for i in range(5)] == [large.draw(i) for i in range(5)]
    other = Plan(load_campaign(_campaign(tmp_path, 5, seed=12, name="c.yaml")).campaign)
    assert other.draw(0) != small.draw(0)


def test_with_grid_axes_a_run_is_shared_only_where_it_falls_in_the_same_cell() -> None:
    # every_distribution.yaml (a grid of two estimators) as `sweep --runs 2` and `--runs 15` run it
    campaign = load_campaign(EVERY).campaign
    small, large = (Plan(campaign.model_copy(update={"runs": runs})) for runs in (2, 15))
    for i in range(len(small)):
        a, b = small.draw(i), large.draw(i)
        # the seed and the random draws follow the run's index alone, the grid's values its cell
        assert (a.seed, a.values["robot.initial_state.theta"]) == (
            b.seed,
            b.values["robot.initial_state.theta"],
        )
        assert (a == b) == (i // 2 == i // 15)
    assert small.draw(2).values["estimator.type"] == "ekf"
    assert large.draw(2).values["estimator.type"] == "constrained-observer"


def test_grid_axes_give_every_cell_runs_times() -> None:
    plan = Plan(load_campaign(DATA / "valid" / "grid_only.yaml").campaign)
    cells = [tuple(plan.draw(i).values.values()) for i in range(len(plan))]
    assert cells == [(0.01, 15), (0.01, 20), (0.02, 15), (0.02, 20)]
    every = Plan(load_campaign(EVERY).campaign)
    assert len(every) == 6
    types = [every.draw(i).values["estimator.type"] for i in range(6)]
    assert types == ["constrained-observer"] * 3 + ["ekf"] * 3


@pytest.mark.parametrize(
    ("successes", "trials", "lo", "hi"),
    [
        # R: binom.test(x, n)$conf.int
        (0, 10, 0.0, 0.3084971),
        (10, 10, 0.6915029, 1.0),
        (5, 10, 0.1870860, 0.8129140),
        (95, 100, 0.8871651, 0.9835681),
        # closed forms at the ends: 1 - 0.025^(1/n) and 0.025^(1/n)
        (0, 2000, 0.0, 1 - 0.025 ** (1 / 2000)),
        (2000, 2000, 0.025 ** (1 / 2000), 1.0),
    ],
)
def test_clopper_pearson_known_values(successes: int, trials: int, lo: float, hi: float) -> None:
    got = clopper_pearson(successes, trials)
    assert got == pytest.approx((lo, hi), abs=5e-7)


@pytest.mark.parametrize("trials", [1, 2, 7, 99, 100, 101, 2000, 10**5, 10**7])
def test_clopper_pearson_closed_forms_and_symmetry(trials: int) -> None:
    """Where the beta quantiles have closed forms (0, 1, n - 1 or n successes of
    n: Beta(1, n) and Beta(n, 1)), the interval has their digits, to 1e-12
    (relative) up to ten million runs; and swapping successes and failures
    mirrors the interval."""
    lower_one = -math.expm1(math.log1p(-0.025) / trials)  # 1 - 0.975^(1/n)
    upper_all_but_one = 0.975 ** (1 / trials)
    assert clopper_pearson(0, trials)[1] == pytest.approx(
        -math.expm1(math.log(0.025) / trials), rel=1e-12
    )
    assert clopper_pearson(trials, trials)[0] == pytest.approx(0.025 ** (1 / trials), rel=1e-12)
    assert clopper_pearson(1, trials)[0] == pytest.approx(lower_one, rel=1e-12)
    assert clopper_pearson(trials - 1, trials)[1] == pytest.approx(upper_all_but_one, rel=1e-12)
    counts = {0, 1, 2, 3, 10, trials // 10, trials // 2, int(0.866 * trials), trials - 1, trials}
    for successes in sorted(c for c in counts if 0 <= c <= trials):
        lo, hi = clopper_pearson(successes, trials)
        mirrored_lo, mirrored_hi = clopper_pearson(trials - successes, trials)
        assert 0.0 <= lo <= successes / trials <= hi <= 1.0
        assert lo < hi
        assert lo == pytest.approx(1.0 - mirrored_hi, rel=1e-12, abs=1e-15)
        assert hi == pytest.approx(1.0 - mirrored_lo, rel=1e-12, abs=1e-15)


@pytest.mark.parametrize(
    ("seconds_per_run", "runs", "workers"),
    [(0.0045, 2000, 2), (0.0045, 2000, 1), (0.0045, 10, 2), (0.5, 7, 3), (1e-4, 10**6, 8)],
)
def test_tasks_cover_every_run_once_and_shrink_at_the_end(
    seconds_per_run: float, runs: int, workers: int
) -> None:
    batches = tasks(seconds_per_run, runs, workers)
    assert [run for batch in batches for run in batch] == list(range(runs))
    sizes = [len(batch) for batch in batches]
    size = task_size(seconds_per_run, runs, workers)
    assert max(sizes) == size
    assert sizes == sorted(sizes, reverse=True)  # the short ones last
    # toward the end, no task longer than half a worker's share of what is left,
    # or than LAST_TASK_SECONDS of runs
    least = max(1, round(LAST_TASK_SECONDS / seconds_per_run))
    left = runs
    for length in sizes:
        assert length in (size, left) or length <= max(math.ceil(left / (2 * workers)), least)
        left -= length


def test_the_last_tasks_end_together() -> None:
    """2000 runs of 4.5 ms on 2 workers: the last task is a twentieth of a
    second, not a whole half-second task that one worker runs alone."""
    sizes = [len(batch) for batch in tasks(0.0045, 2000, 2)]
    assert sizes[0] == 111  # about half a second
    assert sizes[-1] * 0.0045 <= 0.06


@pytest.mark.slow
@pytest.mark.parametrize(("after_seconds", "loaded_in"), [(2.0, "_write_worst"), (0.0, "_execute")])
@pytest.mark.usefixtures("campaign_figures_only")
def test_matplotlib_is_loaded_while_the_runs_run_only_when_they_last(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, after_seconds: float, loaded_in: str
) -> None:
    """A campaign of a second or less loads matplotlib after its runs, so that
    its import never counts in the runs' time (missions_per_second); a longer
    one loads it while the workers run."""
    from wmr_mission.campaign import sweep

    callers: list[str] = []
    load = sweep._load_matplotlib

    def recorded() -> None:
        callers.append(sys._getframe(1).f_code.co_name)
        load()

    monkeypatch.setattr(sweep, "_load_matplotlib", recorded)
    monkeypatch.setattr(sweep, "LOAD_EARLY_AFTER_SECONDS", after_seconds)
    run_campaign(_campaign(tmp_path, 6), out=tmp_path / "out", workers=2, plots=True)
    assert callers[0] == loaded_in
    assert (tmp_path / "out" / "trajectories.png").is_file()


def test_a_value_the_mission_refuses_is_reported_not_run() -> None:
    loaded = load_campaign(EVERY)
    mission, reason = mission_of(loaded, Draw(0, 1, {"robot.dt": -0.5}))
    assert mission is None
    assert "--set robot.dt=-0.5" in reason
    assert "robot.dt: should be greater than 0" in reason
    assert INVALID == "invalid"


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8", newline="") as stream:
        return list(csv.DictReader(stream))


@pytest.mark.slow
@pytest.mark.parametrize(
    "processes",
    # worker threads by default (fast); worker processes, which unpickle the campaign,
    # with the full sweeps
    [False, pytest.param(True, marks=pytest.mark.sweep)],
)
def test_same_rows_on_one_or_two_workers_and_dask(tmp_path: Path, processes: bool) -> None:
    import distributed  # in the test extra

    serial = run_campaign(EVERY, out=tmp_path / "serial", workers=1)
    pool = run_campaign(EVERY, out=tmp_path / "pool", workers=2)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, dashboard_address=None, processes=processes
    ) as cluster:
        dask = run_campaign(EVERY, out=tmp_path / "dask", scheduler=cluster.scheduler_address)
    first = (tmp_path / "serial" / "runs.csv").read_bytes()
    assert (tmp_path / "pool" / "runs.csv").read_bytes() == first
    assert (tmp_path / "dask" / "runs.csv").read_bytes() == first
    header = first.split(b"\n", 1)[0].decode().split(",")
    assert header[:3] == ["run", "seed", "outcome"]
    assert header[3:7] == [
        "robot.initial_state.theta",
        "estimator.initial_estimate.x",
        "controller.Q",
        "estimator.type",
    ]
    assert "final_position_error" in header
    for result in (serial, pool, dask):
        assert result.summary["runs"] == 6
        assert [row["run"] for row in result.rows] == list(range(6))
        assert list(result.to_dataframe()["run"]) == list(range(6))
    assert dask.summary["scheduler"] == cluster.scheduler_address


@pytest.mark.slow
def test_campaign_outputs_and_replay_of_the_worst_run(tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = run_campaign(_campaign(tmp_path, 16), out=out, workers=2)
    record = json.loads((out / "campaign.json").read_text(encoding="utf-8"))
    rows = _rows(out / "runs.csv")
    assert record == json.loads(json.dumps(result.summary))
    assert record["runs"] == len(rows) == 16
    assert record["succeeded"] == sum(r["outcome"] == "success" for r in rows)
    lo, hi = record["success_interval"]
    assert lo <= record["success_rate"] <= hi
    assert sum(record["outcomes"].values()) == 16
    assert record["interrupted"] is False
    assert record["missions_per_second"] > 0
    errors = [float(r["final_position_error"]) for r in rows if r["final_position_error"]]
    assert record["metrics"]["final_position_error"]["max"] == max(errors)
    manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    assert manifest["resolved_campaign"]["runs"] == 16
    assert manifest["loop"] == ("compiled" if jit.compiling() else "plain Python")

    # Each worst run has its directory, those of the workers and the one this process takes
    written = sorted(int(d.name) for d in (out / "worst").iterdir())
    assert written == sorted(w["run"] for w in record["worst"])
    assert len(written) == 5
    worst = record["worst"][0]
    row = rows[worst["run"]]
    assert row["outcome"] == worst["outcome"]
    # The worst directory is the run re-simulated; the replay command reproduces it.
    words = shlex.split(worst["replay"])
    assert words[:2] == ["wmr-mission", "run"]
    replay = tmp_path / "replay"
    subprocess.run(
        [sys.executable, "-m", "wmr_mission", *words[1:], "--out", str(replay), "--no-plots"],
        capture_output=True,
        check=False,
    )
    kept = out / "worst" / str(worst["run"])
    assert (replay / "trajectory.csv").read_bytes() == (kept / "trajectory.csv").read_bytes()
    summary = json.loads((replay / "summary.json").read_text(encoding="utf-8"))
    assert summary["outcome"] == row["outcome"]
    assert repr(summary["final"]["position_error"]) == row["final_position_error"]
    assert summary["seed"] == int(row["seed"])


@pytest.mark.parametrize("stage", ["runs", "worst"])
def test_a_ctrl_c_inside_a_run_stops_the_campaign_never_the_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, stage: str
) -> None:
    """``run_mission`` turns a Ctrl-C into an ``interrupted`` result; in a
    campaign that is the campaign's Ctrl-C: no row and no worst-run directory
    says ``interrupted`` (neither would be what its replay gives), the sweep
    exits 130 and keeps what finished."""
    from wmr_mission.record import Outcome
    from wmr_mission.sim import runner

    real = runner.run_mission
    calls = {"runs": 0, "worst": 0}

    def ctrl_c_on_the_fourth(*args: Any, **kwargs: Any) -> Any:
        kind = "worst" if "seed" in kwargs else "runs"  # a worst run is re-simulated with its seed
        calls[kind] += 1
        result = real(*args, **kwargs)
        if kind == stage and calls[kind] == 4:
            result.outcome = Outcome.interrupted
        return result

    monkeypatch.setattr(runner, "run_mission", ctrl_c_on_the_fourth)
    out = tmp_path / "out"
    code = sweep_command(_campaign(tmp_path, 8), out=out, workers=1, scheduler=None, plots=False)
    assert code == 130
    record = json.loads((out / "campaign.json").read_text(encoding="utf-8"))
    assert record["interrupted"] is True
    rows = _rows(out / "runs.csv")
    assert all(r["outcome"] != "interrupted" for r in rows)
    assert len(rows) == record["runs"]
    assert (len(rows) == 8) is (stage == "worst")  # stopped in the runs: the cut task's rows lost
    written = list((out / "worst").iterdir()) if (out / "worst").exists() else []
    assert len(written) == (3 if stage == "worst" else 0)
    for directory in written:
        summary = json.loads((directory / "summary.json").read_text(encoding="utf-8"))
        assert summary["outcome"] != "interrupted"


@pytest.mark.slow
def test_ctrl_c_keeps_finished_runs(tmp_path: Path) -> None:
    out = tmp_path / "out"
    process = subprocess.Popen(
        [sys.executable, "-m", "wmr_mission", "sweep", str(_campaign(tmp_path, 5000)),
         "--out", str(out), "--workers", "2", "--no-plots"],
        cwd=tmp_path,
        env=the_tests_package(dict(os.environ)),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,  # its own process group, as a shell's foreground job
    )  # fmt: skip
    runs_csv = out / "runs.csv"
    # long enough for the warm-up to compile the loop cold on a loaded machine
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:
        if runs_csv.is_file() and runs_csv.read_bytes().count(b"\n") > 20:
            break
        time.sleep(0.1)
    os.killpg(process.pid, signal.SIGINT)  # Ctrl-C reaches the parent and its workers
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    assert b"Traceback" not in stderr
    record = json.loads((out / "campaign.json").read_text(encoding="utf-8"))
    rows = _rows(runs_csv)
    assert record["interrupted"] is True
    assert 20 <= record["runs"] == len(rows) < 5000
    assert record["planned_runs"] == 5000
    assert [int(r["run"]) for r in rows] == sorted(int(r["run"]) for r in rows)
    assert all(r["outcome"] for r in rows)


def test_sweep_exit_codes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """1 and nothing run for an axis value the mission refuses; 1 for an expect not met."""
    refused = DATA / "invalid" / "grid_value_breaks_mission.yaml"
    code = sweep_command(refused, out=tmp_path / "refused", workers=1, scheduler=None, plots=False)
    assert code == 1
    assert f"{refused}:7:3: vary 'robot.dt' (grid) at -0.01: " in capsys.readouterr().err
    assert not (tmp_path / "refused").exists()

    strict = tmp_path / "strict.yaml"
    strict.write_text(
        f"""version: 1
name: strict
mission: {DATA / "short.yaml"}
runs: 2
vary:
  expect.final_position_error.max: {{grid: [1.0e-9]}}
expect:
  success_rate: {{min: 0.5}}
""",
        encoding="utf-8",
    )
    code = sweep_command(strict, out=tmp_path / "strict", workers=1, scheduler=None, plots=False)
    assert code == 1
    # at the campaign's own key, as a mission's messages are (line 8, its `success_rate`)
    assert f"{strict}:8:3: expectation not met: success_rate = 0 (min 0.5)" in (
        capsys.readouterr().err
    )
    record = json.loads((tmp_path / "strict" / "campaign.json").read_text(encoding="utf-8"))
    assert record["outcomes"] == {"expect-failed": 2}
    assert record["expectations"] == [
        {"metric": "success_rate", "min": 0.5, "value": 0.0, "met": False, "verdict": "not met"}
    ]


def test_a_run_that_raises_becomes_an_error_row(monkeypatch: pytest.MonkeyPatch) -> None:
    from wmr_mission.campaign import checked
    from wmr_mission.campaign import rows as runs

    loaded = load_campaign(DATA / "valid" / "grid_only.yaml")
    real = checked.mission_of

    def faulty(loaded: Any, draw: Draw) -> Any:
        if draw.run == 1:
            raise ZeroDivisionError("float division by zero")
        return real(loaded, draw)

    monkeypatch.setattr(checked, "mission_of", faulty)
    rows = runs.run_rows(loaded, 0, 3)
    assert [row.outcome for row in rows] == ["success", runs.ERROR, "success"]
    assert rows[1].reason.startswith("internal error (ZeroDivisionError: float division by zero)")
    assert rows[1].values == (0.01, 20)


def test_a_task_sets_up_its_runs_before_it_simulates_the_first(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # drawn and written into their plans one after another, then simulated:
    # each set-up right after a simulation costs several times as much
    # (docs/performance.md); a fault in one run's set-up is that run's row
    from wmr_mission.campaign import rows as runs
    from wmr_mission.campaign.written import Written
    from wmr_mission.sim import runner

    loaded = load_campaign(DATA / "valid" / "grid_only.yaml")
    events: list[str] = []
    written, simulated = Written.run, runner.run_mission

    def set_up(self: Written, draw: Draw) -> Any:
        events.append(f"set up {draw.run}")
        if draw.run == 1:
            raise ZeroDivisionError("float division by zero")
        return written(self, draw)

    def simulate(mission: Any, **options: Any) -> Any:
        events.append("simulated")
        return simulated(mission, **options)

    monkeypatch.setattr(Written, "run", set_up)
    monkeypatch.setattr(runner, "run_mission", simulate)
    rows = runs.run_rows(loaded, 0, 3)
    assert events == ["set up 0", "set up 1", "set up 2", "simulated", "simulated"]
    assert [row.outcome for row in rows] == ["success", runs.ERROR, "success"]
    assert rows[1].reason.startswith("internal error (ZeroDivisionError: float division by zero)")
    assert [row.run for row in rows] == [0, 1, 2]


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _watch(monkeypatch: pytest.MonkeyPatch, stream: io.StringIO, *names: str) -> dict[str, str]:
    """What ``stream`` shows when each of sweep's functions ``names`` is called."""
    from wmr_mission.campaign import sweep

    seen: dict[str, str] = {}

    def watching(name: str, function: Any) -> Any:
        def watched(*arguments: Any) -> Any:
            seen[name] = stream.getvalue()
            return function(*arguments)

        return watched

    for name in names:
        monkeypatch.setattr(sweep, name, watching(name, getattr(sweep, name)))
    return seen


@pytest.mark.usefixtures("campaign_figures_only")
def test_sweep_shows_each_step_as_it_starts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On a terminal: the first step before the kernels load, the runs counted
    with their success and time left, then drawing as a step of its own."""
    from wmr_mission.campaign import sweep

    stream = _Terminal()
    seen = _watch(monkeypatch, stream, "warm_up", "_draw")
    loaded = load_campaign(DATA / "valid" / "grid_only.yaml")
    out = sweep._prepare(loaded, tmp_path / "c", 1, None, suffix=False)
    with StopSignals() as stop:
        sweep._campaign(
            loaded,
            out_dir=out,
            workers=1,
            scheduler=None,
            plots=True,
            progress_stream=stream,
            keep_rows=None,
            stop=stop,
        )
    assert "starting" in seen["warm_up"]
    assert "runs" not in seen["warm_up"]
    assert "4/4 runs, success 100.0%, 0 s left" in seen["_draw"]
    assert "worst runs and figures" in seen["_draw"]
    quiet = io.StringIO()  # not a terminal: nothing in logs
    with StopSignals() as stop:
        sweep._campaign(
            loaded,
            out_dir=None,
            workers=1,
            scheduler=None,
            plots=False,
            progress_stream=quiet,
            keep_rows=None,
            stop=stop,
        )
    assert quiet.getvalue() == ""


def test_sweep_says_at_once_that_it_was_interrupted(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """When the runs stop on Ctrl-C, the notice comes before campaign.json is written."""
    from wmr_mission.campaign import engine, sweep

    def stopped(*arguments: Any, **options: Any) -> Any:
        yield from []
        raise engine.Interrupted

    monkeypatch.setattr(sweep, "execute", stopped)
    stream = _Terminal()
    seen = _watch(monkeypatch, stream, "_record")
    loaded = load_campaign(DATA / "valid" / "grid_only.yaml")
    with StopSignals() as stop:
        record = sweep._campaign(
            loaded,
            out_dir=None,
            workers=1,
            scheduler=None,
            plots=False,
            progress_stream=stream,
            keep_rows=None,
            stop=stop,
        ).record
    assert record["interrupted"]
    assert sweep.INTERRUPTED_NOTICE in seen["_record"]


def test_aggregate_keeps_a_bounded_number_of_paths_and_the_worst_runs() -> None:
    from wmr_mission.campaign.aggregate import DRAWN_FAILURES, DRAWN_PATHS, WORST_RUNS, Aggregate
    from wmr_mission.campaign.rows import METRICS, Row

    loaded = load_campaign(EVERY)
    aggregate = Aggregate(dict(loaded.campaign.vary))
    path = np.zeros((2, 600), dtype=np.float32)
    values = (0.0, -1.0, [1, 1, 1], "ekf")
    total = 3 * (DRAWN_PATHS + DRAWN_FAILURES)
    for run in range(total):
        failed = run % 3 == 0
        error = float(run % 97) / 1000
        metrics = tuple(error if name == "final_position_error" else 0.0 for name in METRICS)
        outcome = "timeout" if failed else "success"
        aggregate.add(Row(run, run, outcome, values, metrics, "", path))
    kept = aggregate.drawn
    assert sum(ok for ok, _ in kept) == DRAWN_PATHS
    assert sum(not ok for ok, _ in kept) == DRAWN_FAILURES
    worst = aggregate.worst_runs()
    assert len(worst) == WORST_RUNS
    # failures first, the largest final position error first, then the earliest run
    failed_errors = sorted(((run % 97, -run) for run in range(0, total, 3)), reverse=True)[
        :WORST_RUNS
    ]
    assert [run for run, *_ in worst] == [-minus for _, minus in failed_errors]
    statistics = aggregate.statistics()
    assert statistics["runs"] == total
    assert statistics["succeeded"] == total - len(range(0, total, 3))


@pytest.mark.sweep
def test_case2_headings_campaign_in_full(tmp_path: Path) -> None:
    """The shipped 2000-run case-2 campaign: statistics consistent with its rows,
    and the worst run's replay gives its row again."""
    out = tmp_path / "out"
    result = run_campaign(ROOT / "missions" / "campaigns" / "case2-headings.yaml", out=out)
    record = result.summary
    rows = _rows(out / "runs.csv")
    assert record["runs"] == len(rows) == 2000
    assert record["succeeded"] == sum(r["outcome"] == "success" for r in rows)
    lo, hi = record["success_interval"]
    assert lo < record["success_rate"] < hi
    assert hi - lo < 0.05  # 2000 runs pin the rate down to a few per cent
    worst = record["worst"][0]
    words = shlex.split(worst["replay"])
    replay = tmp_path / "replay"
    subprocess.run(
        [sys.executable, "-m", "wmr_mission", *words[1:], "--out", str(replay), "--no-plots"],
        capture_output=True,
        check=False,
    )
    summary = json.loads((replay / "summary.json").read_text(encoding="utf-8"))
    row = rows[worst["run"]]
    assert summary["outcome"] == row["outcome"] == worst["outcome"]
    assert repr(summary["max_constraint_violation"]) == row["max_constraint_violation"]
    assert repr(summary["final"]["position_error"]) == row["final_position_error"]


def _lagging_circle_run() -> Any:
    """circle_run with each reference point 20 samples ahead on the robot's own
    circle: the robot is on the path (a few micrometres off its chords), 2 cm
    behind its own reference point."""
    import dataclasses

    from test_output_synthetic import DT, RADIUS, TURN_RATE, circle_run

    run = circle_run()
    ahead = TURN_RATE * (run.t + 20 * DT)
    tracking = np.isfinite(run.x_ref)
    x_ref = np.where(tracking, RADIUS * np.cos(ahead), np.nan)
    y_ref = np.where(tracking, RADIUS * np.sin(ahead), np.nan)
    return dataclasses.replace(run, x_ref=x_ref, y_ref=y_ref)


def test_a_row_is_judged_as_judge_judges_it_on_either_side_of_the_bound() -> None:
    """judge_run_metrics checks a tracking threshold against the distance to the
    own reference point first; between that bound and the true distance to the
    path it must fall back to the latter, and it always agrees with judge."""
    import copy

    from wmr_mission.record import Outcome
    from wmr_mission.verdicts.metrics import judge, judge_run_metrics, summarize

    def mission(limit: float) -> dict[str, Any]:
        expect = {"settle_time": 1.0, "tracking_error_max": {"max": limit}}
        phases = [{"name": name, "expect": {}} for name in ("approach", "orbit", "park")]
        return {"expect": expect, "phases": phases}

    run = _lagging_circle_run()
    orbit = summarize(run, mission(1.0))["phases"][1]["tracking_error"]
    exact, bound = orbit["max"], orbit["reference_error_rms"]  # the lag is the same at every sample
    assert exact < bound / 100
    outcomes = []
    for limit in (2 * bound, bound / 2, exact / 2):
        judged, fast = copy.deepcopy(run), copy.deepcopy(run)
        summary = judge(judged, mission(limit))
        metrics = judge_run_metrics(fast, mission(limit))
        assert (fast.outcome, fast.message) == (judged.outcome, judged.message)
        missed = metrics.pop("missed")
        assert metrics == {key: summary[key] for key in metrics}
        # the checks it missed, as data: summary.json's, exactly
        assert missed == [c for c in summary["expectations"] if not c["met"]]
        outcomes.append(fast.outcome)
    assert outcomes == [Outcome.success, Outcome.success, Outcome.expect_failed]


@pytest.mark.slow
def test_a_row_is_the_run_its_replay_runs() -> None:
    """Each row (mission checked once, compiled per run, judged on the run's
    metrics alone) is the run `run --set ... --seed` gives: its outcome, message,
    metrics and path, over case2-headings runs that succeed and that fail."""
    from wmr_mission.campaign.comparison import comparison_metrics
    from wmr_mission.campaign.rows import METRICS, PATH_POINTS, run_row, simulate
    from wmr_mission.spec import catalog
    from wmr_mission.verdicts.metrics import summarize, summary_value

    loaded = load_campaign(ROOT / "missions" / "campaigns" / "case2-headings.yaml")
    plan = Plan(loaded.campaign)
    outcomes = set()
    # runs 0..23 all succeed; 105 and 287 fail (max_constraint_violation, spiral-out)
    for run in [*range(12), 105, 287]:
        draw = plan.draw(run)
        row = run_row(loaded, draw)
        result, reason = simulate(loaded, draw)
        assert result is not None, reason
        summary = summarize(result, result.mission)
        metrics = (
            *(summary_value(summary, m.where) for m in catalog.run_metrics()),
            summary_value(summary, ("clearance_min",)),
            *comparison_metrics(result, result.mission),
        )
        assert len(metrics) == len(METRICS)
        assert row.outcome == result.outcome.value
        assert row.reason == ("" if row.succeeded else result.message)
        assert row.metrics == metrics
        # the run's margin: runs.csv's is summary.json's, and so are the checks it missed
        written = result.summary()
        assert (row.margin, row.margin_check) == (written["margin"], written["margin_check"])
        missed = [c for c in written.get("expectations", []) if not c["met"]]
        # (a run's directory also says when each first failed: first_violation)
        assert [c.record() for c in row.missed] == [
            {k: v for k, v in c.items() if k != "first_violation"} for c in missed
        ]
        step = -(-result.samples // PATH_POINTS)
        assert (
            row.path_xy.tobytes()
            == np.vstack([result.x[::step], result.y[::step]]).astype(np.float32).tobytes()
        )
        outcomes.add(row.outcome)
    assert len(outcomes) >= 2, outcomes  # successes and failures both compared


def test_a_value_that_breaks_a_check_across_fields_is_reported_not_run(tmp_path: Path) -> None:
    """A run's own check covers the checks across fields: a start outside the
    region the first phase must stay inside (the axis's extremes are inside)."""
    path = tmp_path / "start.yaml"
    path.write_text(
        f"version: 1\nname: start\nmission: {DATA / 'short.yaml'}\nruns: 2\n"
        "vary:\n  robot.initial_state.x: {uniform: [-1.0, 1.0]}\n",
        encoding="utf-8",
    )
    loaded = load_campaign(path)
    mission, reason = mission_of(loaded, Draw(0, 1, {"robot.initial_state.x": 5.0}))
    assert mission is None
    assert "robot.initial_state (5, 0.5) is outside region 'yard'" in reason
    mission, reason = mission_of(loaded, Draw(0, 1, {"robot.initial_state.x": 0.5}))
    assert mission is not None
    assert mission.robot.initial_state.x == 0.5
    assert reason == ""


def test_a_normal_draw_beyond_the_checked_extremes_gets_every_check(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """validate ran the sampling checks at mean +- 4 std: a draw within needs
    only the run's own checks, a draw beyond gets the mission's every check."""
    from wmr_mission.campaign import checked as runs

    loaded = load_campaign(EVERY)  # estimator.initial_estimate.x: normal [-1.0, 0.1]
    axis = loaded.campaign.vary["estimator.initial_estimate.x"]
    assert axis.within_extremes(-1.4)
    assert not axis.within_extremes(-1.4001)
    checked: list[float] = []
    real = runs.checked_mission

    def counted(loaded: Any, draw: Draw) -> Any:
        checked.append(draw.values["estimator.initial_estimate.x"])
        return real(loaded, draw)

    monkeypatch.setattr(runs, "checked_mission", counted)
    values = Plan(loaded.campaign).draw(0).values
    for x in (-1.0, -1.4, -1.5):
        mission, reason = runs.mission_of(
            loaded, Draw(0, 1, {**values, "estimator.initial_estimate.x": x})
        )
        assert mission is not None
        assert reason == ""
        assert mission.estimator.initial_estimate is not None
        assert mission.estimator.initial_estimate.x == x
    assert checked == [-1.5]


def test_a_row_is_judged_as_judge_judges_it_on_every_phase_threshold() -> None:
    """The row's verdict reads only what the thresholds need of each phase:
    every kind of phase threshold, met and missed, gives judge's outcome and
    message."""
    import copy

    from wmr_mission.record import Outcome
    from wmr_mission.verdicts.metrics import judge, judge_run_metrics

    run = _lagging_circle_run()
    run.omega = run.omega.copy()
    run.omega[700:800] = 20.0 * (-1.0) ** np.arange(100)  # chatter at the limit in orbit
    everything = {
        "settle_time": 1.0,
        "tracking_error_rms": {"max": 0.5},
        "tracking_error_max": {"max": 0.5},
        "speed_at_limit": {"max": 0.01},
        "turn_rate_at_limit": {"max": 0.01},
        "turn_rate_jitter": {"max": 1.0},
        "turn_rate_reversals": {"max": 10},
        "estimation_rms": {"x": 1e-3, "y": 1.0, "theta": None},
    }
    for approach in ({}, {"estimation_rms": {"x": 1e-9, "y": None, "theta": None}}):
        names = ("approach", "orbit", "park")
        phases = [{"name": n, "expect": approach if n == "approach" else {}} for n in names]
        mission = {"expect": everything, "phases": phases}
        judged, fast = copy.deepcopy(run), copy.deepcopy(run)
        judge(judged, mission)
        judge_run_metrics(fast, mission)
        assert fast.outcome is judged.outcome is Outcome.expect_failed
        assert fast.message == judged.message
        assert "orbit: turn_rate_at_limit" in fast.message
    assert "approach: estimation_rms.x" in fast.message


def test_a_row_measures_of_each_phase_only_what_its_thresholds_read(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """With only turn_rate_at_limit set, the row's verdict measures neither the
    tracking error, the tracking against the timed reference, the zones nor the
    input quality of any phase (they cost more than the rest of the verdict),
    and still gives judge's outcome and message."""
    import copy

    from wmr_mission.record import Outcome
    from wmr_mission.verdicts import metrics

    run = _lagging_circle_run()
    run.omega = run.omega.copy()
    run.omega[700:800] = 20.0 * (-1.0) ** np.arange(100)  # chatter at the limit in orbit
    phases = [{"name": n, "expect": {}} for n in ("approach", "orbit", "park")]
    mission = {
        "expect": {"settle_time": 1.0, "turn_rate_at_limit": {"max": 0.01}},
        "phases": phases,
    }
    judged, fast = copy.deepcopy(run), copy.deepcopy(run)
    metrics.judge(judged, mission)

    def unread(*_: Any) -> None:
        raise AssertionError("measured, but no threshold reads it")

    for name in (
        "_off_path_bound",
        "distance_to_path",
        "track_samples",
        "intrusion_max",
        "regulated",  # a regulate phase's stall and overshoot
    ):
        monkeypatch.setattr(metrics, name, unread)
    monkeypatch.setattr(metrics.input_metrics, "input_quality", unread)
    metrics.judge_run_metrics(fast, mission)
    assert fast.outcome is judged.outcome is Outcome.expect_failed
    assert fast.message == judged.message
    assert "orbit: turn_rate_at_limit" in fast.message


def test_a_run_leaves_the_mission_it_varies_as_read(tmp_path: Path) -> None:
    """Each run sets its values in a copy of the sections they are in (robot,
    and robot.disturbances, which the file leaves out), and shares the others
    with every run: the mission read once per campaign stays as read."""
    import copy

    path = tmp_path / "c.yaml"
    path.write_text(
        f"version: 1\nname: c\nmission: {DATA / 'short.yaml'}\nruns: 6\nvary:\n"
        "  robot.initial_state.x: {uniform: [-1.5, -0.5]}\n"
        "  robot.disturbances.input_delay: {choice: [0.0, 0.04]}\n",
        encoding="utf-8",
    )
    loaded = load_campaign(path)
    read = copy.deepcopy(loaded.mission_document.data)
    plan = Plan(loaded.campaign)
    delays = set()
    for run in range(len(plan)):
        draw = plan.draw(run)
        mission, reason = mission_of(loaded, draw)
        assert mission is not None, reason
        assert mission.robot.initial_state.x == draw.values["robot.initial_state.x"]
        assert (
            mission.robot.disturbances.input_delay == draw.values["robot.disturbances.input_delay"]
        )
        delays.add(mission.robot.disturbances.input_delay)
    assert delays == {0.0, 0.04}
    assert loaded.mission_document.data == read


@pytest.mark.usefixtures("campaign_figures_only")
def test_sweep_draws_its_figures_with_one_image_per_outcome(tmp_path: Path) -> None:
    """The figures are written, and the trajectories are one image per outcome
    whatever the number of runs (2000 lines as one artist each took seconds,
    as one collection still 1.4 s)."""
    from matplotlib.image import AxesImage

    from wmr_mission.campaign import figures

    out = tmp_path / "drawn"
    code = sweep_command(_campaign(tmp_path, 6), out=out, workers=1, scheduler=None, plots=True)
    assert code in (0, 1)
    for name in ("trajectories", "metrics", "success"):
        assert (out / f"{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    loaded = load_campaign(_campaign(tmp_path, 1))
    regions = {"yard": {"type": "box", "min": [-3, -2], "max": [2, 2]}}
    artists = []
    for runs in (3, 30):
        aggregate = figures.Aggregate(dict(loaded.campaign.vary))
        for run in range(runs):
            path = np.vstack([np.linspace(-1, 0, 50), np.full(50, 0.05 * run)]).astype(np.float32)
            aggregate.drawn.append((run % 3 != 0, path))
            aggregate.drawn_failures += run % 3 == 0
        panels = figures._trajectories(aggregate, regions).axes
        # small multiples: the successes, then the failures, one image each on
        # an axes of its own (no outcome drawn over the other)
        assert len(panels) == 2
        images = [[a for a in ax.get_children() if isinstance(a, AxesImage)] for ax in panels]
        assert [len(i) for i in images] == [1, 1]
        # every run's path shows: one row of pixels per run, on its outcome's panel
        for (image,), outcome in zip(images, (True, False), strict=True):
            pixels = np.asarray(image.get_array())
            rows = np.flatnonzero(pixels[:, :, 3].max(axis=1) > 0)
            assert rows.size == sum(ok is outcome for ok, _ in aggregate.drawn)
        assert "failures: " in panels[1].get_title()
        artists.append(sum(len(ax.get_children()) for ax in panels))
    assert artists[0] == artists[1]  # the same artists for 3 runs as for 30


@pytest.mark.usefixtures("campaign_figures_only")
def test_a_dollar_in_a_varied_value_is_drawn_as_typed(tmp_path: Path) -> None:
    """Values are data: a choice of texts with '$' in them labels the success
    figure's axis as typed (parsed as math, the first stopped the drawing)."""
    campaign = tmp_path / "c.yaml"
    campaign.write_text(
        "version: 1\nname: dollars\nmission: " + str(DATA / "short.yaml") + "\n"
        "runs: 4\nseed: 1\nvary:\n  description: {choice: ['$\\frac{$', 'x']}\n",
        encoding="utf-8",
    )
    out = tmp_path / "out"
    code = sweep_command(campaign, out=out, workers=1, scheduler=None, plots=True)
    assert code in (0, 1)
    assert (out / "success.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_value_between_checked_extremes_is_checked_as_run_checks_it(tmp_path: Path) -> None:
    """A continuous axis of a field the path reads: c = ±1 give a finite path,
    |c| < 0.5 does not. Those runs are invalid, as `run --set` says, never
    simulated (they would be judged diverged)."""
    mission = tmp_path / "m.yaml"
    mission.write_text(
        """version: 1
name: nonmono
parameters: {c: 1.0}
robot: {dt: 0.02, initial_state: {x: 0, y: 0, theta: 0}, limits: {v: 2, omega: 3}}
estimator: {type: constrained-observer}
phases:
  - name: line
    track: {path: {type: expression, x: "0.2*t", y: "sqrt(c*c - 0.25) - sqrt(0.75)"}}
    until: {elapsed: 1}
""",
        encoding="utf-8",
    )
    campaign = tmp_path / "c.yaml"
    campaign.write_text(
        "version: 1\nname: nonmono-c\nmission: m.yaml\nruns: 12\nseed: 1\n"
        "vary:\n  parameters.c: {uniform: [-1.0, 1.0]}\n",
        encoding="utf-8",
    )
    loaded = load_campaign(campaign)
    plan = Plan(loaded.campaign)
    outcomes = []
    for run in range(12):
        draw = plan.draw(run)
        mission_run, _ = mission_of(loaded, draw)
        inside = abs(draw.values["parameters.c"]) < 0.5
        assert (mission_run is None) == inside
        outcomes.append(inside)
    assert any(outcomes)  # values inside the gap were drawn
    assert not all(outcomes)  # and values outside it


def test_a_replay_line_runs_from_the_campaign_directory_and_from_anywhere(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A campaign swept as ``sweep sub/c.yaml`` names its mission relative to
    itself (``mission: quick.yaml``): the replay names it by its absolute path."""
    from typer.testing import CliRunner

    from wmr_mission.cli import app

    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "quick.yaml").write_text((DATA / "short.yaml").read_text())
    (tmp_path / "sub" / "c.yaml").write_text(
        "version: 1\nname: sub\nmission: quick.yaml\nruns: 2\nseed: 3\n"
        "vary:\n  robot.initial_state.theta: {uniform: [-1.0, 1.0]}\n"
    )
    monkeypatch.chdir(tmp_path)
    code = sweep_command(
        Path("sub/c.yaml"), out=Path("out"), workers=1, scheduler=None, plots=False
    )
    assert code == 0
    worst = json.loads((tmp_path / "out" / "campaign.json").read_text())["worst"][0]
    words = shlex.split(worst["replay"])
    assert words[2] == str(tmp_path / "sub" / "quick.yaml")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    kept = (tmp_path / "out" / "worst" / str(worst["run"]) / "trajectory.csv").read_bytes()
    for where in (tmp_path / "out", elsewhere):
        monkeypatch.chdir(where)
        done = CliRunner().invoke(app, [*words[1:], "--out", "replayed", "--no-plots"])
        assert done.exit_code in (0, 1), done.stderr
        assert (where / "replayed" / "trajectory.csv").read_bytes() == kept


@pytest.mark.parametrize(
    ("runs", "workers", "loaded_here"),
    [(2000, 2, True), (2000, None, False), (20, 2, False)],
)
def test_the_judges_passes_are_loaded_before_the_workers_where_they_pay(
    monkeypatch: pytest.MonkeyPatch, runs: int, workers: int | None, loaded_here: bool
) -> None:
    # case 2's runs have about 3 200 samples: 2000 of them on 2 workers judge
    # far beyond JUDGED_COMPILED_FROM each, so the passes load before the
    # fork; 20 do not, and a Dask cluster's workers (None) fork from nothing
    from wmr_mission.campaign.engine import warm_up

    monkeypatch.setattr(jit._state, "judged", 0)
    loaded = load_campaign(ROOT / "missions" / "campaigns" / "case2-headings.yaml")
    loaded.campaign = loaded.campaign.model_copy(update={"runs": runs})
    warm_up(loaded, workers)
    counted = jit._state.judged  # the warm-up's own runs, at most 3 of them
    assert (counted >= jit.JUDGED_COMPILED_FROM) is loaded_here
