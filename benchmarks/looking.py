"""Sizes and times of `wmr-mission view` and `export` (docs/run-directory.md, docs/campaigns.md).

    python benchmarks/looking.py                  # benchmarks/hour.yaml (1 h) and case study 2
    python benchmarks/looking.py --campaign DIR   # also the report of a campaign directory
    python benchmarks/looking.py --large-campaign # also 10 000 runs of the tests' campaign

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

from browser import Page  # noqa: E402

WMR = [sys.executable, "-m", "wmr_mission"]


def _seconds(command: list[str]) -> float:
    started = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - started


def _median(command: list[str], repeat: int) -> float:
    return statistics.median(_seconds(command) for _ in range(repeat))


def _load_ms(page_path: Path) -> tuple[float, list[str]]:
    with Page.open(page_path) as page:
        assert page.evaluate("document.body.dataset.rendered") == "1"
        load = page.evaluate("performance.timing.loadEventEnd - performance.timing.navigationStart")
        return float(load), page.problems()


def report(directory: Path, repeat: int, exports: bool) -> None:
    page = directory / "report.html"
    view = _median([*WMR, "view", str(directory)], repeat)
    loads = [_load_ms(page) for _ in range(repeat)]
    problems = {p for _, found in loads for p in found}
    print(
        f"{directory.name}: view {view:.2f} s, page {page.stat().st_size / 1e6:.2f} MB, "
        f"load in Chromium {statistics.median(ms for ms, _ in loads):.0f} ms "
        f"(console problems: {len(problems)})"
    )
    if not exports:
        return
    for fmt, name in (("parquet", "trajectory.parquet"), ("mcap", "run.mcap")):
        seconds = _median([*WMR, "export", str(directory), "--format", fmt], repeat)
        size = (directory / name).stat().st_size / 1e6
        print(f"{directory.name}: export --format {fmt} {seconds:.2f} s, {size:.1f} MB")


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
            report(out, args.repeat, exports=True)
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
            report(out, args.repeat, exports=False)
    if args.campaign is not None:
        report(args.campaign, args.repeat, exports=False)


if __name__ == "__main__":
    main()
