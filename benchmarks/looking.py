"""Sizes and times of `wmr-mission view` and `export` (docs/run-directory.md, docs/campaigns.md).

    python benchmarks/looking.py                  # benchmarks/hour.yaml (1 h) and case study 2
    python benchmarks/looking.py --campaign DIR   # also the report of a campaign directory
    python benchmarks/looking.py --large-campaign # also 10 000 runs of the tests' campaign
    python benchmarks/looking.py --exports-only   # the exports alone (no Chromium), and the
                                                  # ROS 2 MCAP's CDR against mcap-ros2-support's

For each run: the time of `view` (the command, Python start-up included), the
page's size, and in headless Chromium (tests/browser.py) the time from
navigation to the end of the load event, the report's script included
(`performance.timing`); then the time and size of each export. Medians over
``--repeat`` runs. Timings depend on the machine and on what else runs on it.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))


WMR = [sys.executable, "-m", "wmr_mission"]


def _seconds(command: list[str]) -> float:
    started = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - started


def _median(command: list[str], repeat: int) -> float:
    return statistics.median(_seconds(command) for _ in range(repeat))


def _load_ms(page_path: Path) -> tuple[float, list[str]]:
    from browser import Page

    with Page.open(page_path) as page:
        assert page.evaluate("document.body.dataset.rendered") == "1"
        load = page.evaluate("performance.timing.loadEventEnd - performance.timing.navigationStart")
        return float(load), page.problems()


def exports(directory: Path, repeat: int) -> None:
    for fmt, name in (
        ("parquet", "trajectory.parquet"),
        ("mcap", "run.mcap"),
        ("mcap-json", "run.json.mcap"),
    ):
        seconds = _median([*WMR, "export", str(directory), "--format", fmt], repeat)
        size = (directory / name).stat().st_size / 1e6
        print(f"{directory.name}: export --format {fmt} {seconds:.2f} s, {size:.1f} MB")


def report(directory: Path, repeat: int, exports_too: bool) -> None:
    page = directory / "report.html"
    view = _median([*WMR, "view", str(directory)], repeat)
    loads = [_load_ms(page) for _ in range(repeat)]
    problems = {p for _, found in loads for p in found}
    print(
        f"{directory.name}: view {view:.2f} s, page {page.stat().st_size / 1e6:.2f} MB, "
        f"load in Chromium {statistics.median(ms for ms, _ in loads):.0f} ms "
        f"(console problems: {len(problems)})"
    )
    if exports_too:
        exports(directory, repeat)


def ros2_pair(directory: Path, repeat: int) -> None:
    """The ROS 2 MCAP's odometry and commands as written by export (CDR records)
    against mcap-ros2-support's encoder on the same messages, alternating."""
    import io

    import numpy as np
    from mcap_ros2.writer import Writer

    from wmr_mission.output.reader import load_run
    from wmr_mission.review import ros2_messages as ros2

    r = load_run(directory)
    zeros = [0.0] * 36

    def ours() -> None:
        stream = io.BytesIO()
        from mcap.writer import Writer as Mcap

        writer = Mcap(stream)
        writer.start(profile="ros2", library="bench")
        schema = writer.register_schema(
            "nav_msgs/msg/Odometry",
            "ros2msg",
            ros2.message_definition("nav_msgs/Odometry").encode(),
        )
        channel = writer.register_channel("/odom", "cdr", schema)
        for t, data in ros2._odometry(r.t, r.x, r.y, r.theta, r.v, r.omega):
            ns = round(t * 1e9)
            writer.add_message(channel, ns, data, ns)
        writer.finish()

    def library() -> None:
        writer = Writer(io.BytesIO())
        schema = writer.register_msgdef(
            "nav_msgs/msg/Odometry", ros2.message_definition("nav_msgs/Odometry")
        )
        half = 0.5 * np.asarray(r.theta)
        for k, t in enumerate(r.t.tolist()):
            sec, nanosec = divmod(round(t * 1e9), 1_000_000_000)
            message = {
                "header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": "world"},
                "child_frame_id": "base_link",
                "pose": {
                    "pose": {
                        "position": {"x": float(r.x[k]), "y": float(r.y[k]), "z": 0.0},
                        "orientation": {
                            "x": 0.0,
                            "y": 0.0,
                            "z": float(np.sin(half[k])),
                            "w": float(np.cos(half[k])),
                        },
                    },
                    "covariance": zeros,
                },
                "twist": {
                    "twist": {
                        "linear": {"x": float(r.v[k]), "y": 0.0, "z": 0.0},
                        "angular": {"x": 0.0, "y": 0.0, "z": float(r.omega[k])},
                    },
                    "covariance": zeros,
                },
            }
            writer.write_message("/odom", schema, message, log_time=round(t * 1e9))
        writer.finish()

    times: dict[str, list[float]] = {"export's CDR records": [], "mcap-ros2-support": []}
    for _ in range(repeat):
        for name, write in (("export's CDR records", ours), ("mcap-ros2-support", library)):
            started = time.process_time()
            write()
            times[name].append(time.process_time() - started)
    a, b = (statistics.median(v) for v in times.values())
    print(
        f"{directory.name}: /odom of {r.samples} samples, CPU: export's CDR records {a:.2f} s, "
        f"mcap-ros2-support {b:.2f} s ({b / a:.0f}x)"
    )


def mcap_split(directory: Path) -> None:
    """How MCAP's time divides between making the JSON messages and the writer."""
    import io
    import json

    import numpy as np

    from wmr_mission.output.reader import load_run
    from wmr_mission.review import export

    r = load_run(directory)
    summary = json.loads((directory / "summary.json").read_text(encoding="utf-8"))
    started = time.perf_counter()
    measured = np.where(np.isfinite(r.theta_meas), r.theta_meas, 0.0)
    count = 0
    for messages in (
        export._pose_messages(r.t, r.x, r.y, r.theta),
        export._pose_messages(r.t, r.x_est, r.y_est, r.theta_est),
        export._pose_messages(r.t, r.x_ref, r.y_ref, None),
        export._pose_messages(r.t, r.x_meas, r.y_meas, measured),
        export._sample_messages(r),
    ):
        count += sum(1 for _ in messages)
    made = time.perf_counter() - started
    started = time.perf_counter()
    export.write_mcap(r, summary, io.BytesIO())
    written = time.perf_counter() - started
    print(
        f"{directory.name}: {count} MCAP messages: making them {made:.1f} s, "
        f"all written {written:.1f} s (the writer {written - made:.1f} s)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--campaign", type=Path, help="a campaign directory to report too")
    parser.add_argument(
        "--exports-only", action="store_true", help="time the exports alone (no view, no Chromium)"
    )
    parser.add_argument(
        "--large-campaign",
        action="store_true",
        help="sweep the campaign of tests/conftest.py with 5000 draws per grid cell "
        "(10 000 runs, about a minute on two cores) and report it too",
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        for mission in (ROOT / "benchmarks" / "hour.yaml", ROOT / "missions" / "case2.yaml"):
            out = Path(scratch) / mission.stem
            subprocess.run(
                [*WMR, "run", str(mission), "--out", str(out), "--no-plots"],
                check=True,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
            samples = sum(1 for _ in (out / "trajectory.csv").open()) - 1
            csv_mb = (out / "trajectory.csv").stat().st_size / 1e6
            print(f"{mission.stem}: {samples} samples, trajectory.csv {csv_mb:.1f} MB")
            if args.exports_only:
                exports(out, args.repeat)
                ros2_pair(out, args.repeat)
                continue
            report(out, args.repeat, exports_too=True)
            if mission.stem == "hour":
                mcap_split(out)
        if args.large_campaign:
            from conftest import LOOKING_CAMPAIGN

            campaign = Path(scratch) / "large.yaml"
            mission = ROOT / "tests" / "data" / "campaigns" / "short.yaml"
            text = LOOKING_CAMPAIGN.format(mission=mission).replace("runs: 4", "runs: 5000")
            campaign.write_text(text, encoding="utf-8")
            out = Path(scratch) / "large-campaign"
            subprocess.run(
                [*WMR, "sweep", str(campaign), "--out", str(out)],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )  # exit 0 or 1: the campaign has no expect to meet
            report(out, args.repeat, exports_too=False)
    if args.campaign is not None:
        report(args.campaign, args.repeat, exports_too=False)


if __name__ == "__main__":
    main()
