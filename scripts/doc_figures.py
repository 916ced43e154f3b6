"""The figures of docs/run-directory.md and docs/campaigns.md, made as a user makes them.

    python scripts/doc_figures.py              # the runs' and case2-headings' (a minute or two)
    python scripts/doc_figures.py --run-only   # the runs' figures alone
    python scripts/doc_figures.py --cases-only # docs/case-studies.md's alone

docs/images/disturbed-verdicts.png: `wmr-mission run missions/disturbed.yaml
--set estimator.innovation_gate=null`'s verdicts.png (its outliers ungated, the
mission fails). docs/images/keep-out-xy-one-column.png:
`wmr-mission plot RUN_DIR --style one-column`'s xy.png.
docs/images/patrol-detour-xy.png: `wmr-mission run missions/patrol-detour.yaml`'s
xy.png, its reactions marked; replanned-patrol-xy.png: `wmr-mission run
missions/replanned-patrol.yaml`'s xy.png, its updates marked. docs/images/campaigns/
case2-headings-{trajectories,metrics,success}.png: `wmr-mission sweep
missions/campaigns/case2-headings.yaml`'s figures, and
case2-headings-worst-FAILURE.png: the verdicts.png of the worst run of each
kind of failure (worst/RUN/). docs/images/case1-xy.png, case2-xy.png,
case1-estimation-error.png: `wmr-mission run missions/case1.yaml` (case2)'s
xy.png and estimation_error.png; case2-deviation-free-xy.png: case 2 with
`--set controller.regulation.form=deviation --set 'phases.return.constraints=[]'`.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
IMAGES = ROOT / "docs" / "images"
WMR = [sys.executable, "-m", "wmr_mission"]


def _wmr(*args: str) -> None:
    print("+ wmr-mission " + " ".join(args), flush=True)
    subprocess.run([*WMR, *args], cwd=ROOT, check=False)  # a failing mission exits 1


def run_figures(tmp: Path) -> None:
    failing = tmp / "disturbed"
    _wmr("run", "missions/disturbed.yaml", "--set", "estimator.innovation_gate=null", "--out",
         str(failing))  # fmt: skip
    shutil.copy(failing / "verdicts.png", IMAGES / "disturbed-verdicts.png")
    run_dir = tmp / "keep-out"
    _wmr("run", "missions/keep-out.yaml", "--out", str(run_dir))
    _wmr("plot", str(run_dir), "--style", "one-column")
    shutil.copy(run_dir / "xy.png", IMAGES / "keep-out-xy-one-column.png")
    detoured = tmp / "patrol-detour"
    _wmr("run", "missions/patrol-detour.yaml", "--out", str(detoured))
    shutil.copy(detoured / "xy.png", IMAGES / "patrol-detour-xy.png")
    replanned = tmp / "replanned-patrol"
    _wmr("run", "missions/replanned-patrol.yaml", "--out", str(replanned))
    shutil.copy(replanned / "xy.png", IMAGES / "replanned-patrol-xy.png")


def case_figures(tmp: Path) -> None:
    """The figures of docs/case-studies.md."""
    for case in ("case1", "case2"):
        run_dir = tmp / case
        _wmr("run", f"missions/{case}.yaml", "--out", str(run_dir))
        shutil.copy(run_dir / "xy.png", IMAGES / f"{case}-xy.png")
    shutil.copy(tmp / "case1" / "estimation_error.png", IMAGES / "case1-estimation-error.png")
    free = tmp / "case2-deviation-free"
    _wmr(
        "run", "missions/case2.yaml", "--out", str(free),
        "--set", "controller.regulation.form=deviation",
        "--set", "phases.return.constraints=[]",
    )  # fmt: skip
    shutil.copy(free / "xy.png", IMAGES / "case2-deviation-free-xy.png")


def campaign_figures(tmp: Path) -> None:
    out = tmp / "case2-headings"
    _wmr("sweep", "missions/campaigns/case2-headings.yaml", "--out", str(out))
    for name in ("trajectories", "metrics", "success"):
        shutil.copy(out / f"{name}.png", IMAGES / "campaigns" / f"case2-headings-{name}.png")
    record = json.loads((out / "campaign.json").read_text(encoding="utf-8"))
    for failure in record["failures"]:
        worst = failure["worst"][0]
        shutil.copy(
            out / "worst" / str(worst["run"]) / "verdicts.png",
            IMAGES / "campaigns" / f"case2-headings-worst-{failure['failure']}.png",
        )
        print(
            f"{failure['failure']}: {failure['runs']} runs; worst run {worst['run']} "
            f"({worst['phase']}: {worst['value']} against {worst['max']})"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run-only", action="store_true", help="the runs' figures alone")
    parser.add_argument("--cases-only", action="store_true", help="the case studies' alone")
    arguments = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        case_figures(Path(tmp))
        if arguments.cases_only:
            return
        run_figures(Path(tmp))
        if not arguments.run_only:
            campaign_figures(Path(tmp))


if __name__ == "__main__":
    main()
