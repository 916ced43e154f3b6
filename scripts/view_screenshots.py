"""The screenshots of `wmr-mission view` in docs/images, taken in headless Chromium.

    python scripts/view_screenshots.py                       # runs keep-out and case2-headings
    python scripts/view_screenshots.py --campaign runs/DIR   # an existing case2-headings directory
    python scripts/view_screenshots.py --only run            # view-run.png alone

docs/images/view-run.png: the report of missions/keep-out.yaml (a run that
succeeds), the cursor on the sample where the robot passes the pond. docs/images/view-campaign.png:
the runs of missions/campaigns/case2-headings.yaml that failed, the largest
constraint violation first.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from browser import Page  # noqa: E402

IMAGES = ROOT / "docs" / "images"
WMR = [sys.executable, "-m", "wmr_mission"]
WIDTH, HEIGHT = 1280, 860


def _wmr(*args: str) -> None:
    subprocess.run([*WMR, *args], check=True, cwd=ROOT, stdout=subprocess.DEVNULL)


def run_screenshot(scratch: Path) -> None:
    run = scratch / "keep-out"
    subprocess.run(
        [*WMR, "run", "missions/keep-out.yaml", "--out", str(run), "--no-plots"],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    _wmr("view", str(run))
    with Page.open(run / "report.html", width=WIDTH, height=HEIGHT) as page:
        assert page.problems() == []
        box = page.evaluate(
            "(() => { const r = document.querySelector('canvas[data-plot=\"x\"]')"
            ".getBoundingClientRect(); return [r.x, r.y, r.width]; })()"
        )
        x, y, width = box
        # t = 5 s of 98.08 s: the robot beside the pond
        page.mouse("mouseMoved", x + 60 + (width - 72) * 5.0 / 98.08, y + 40)
        assert page.problems() == []
        page.screenshot(IMAGES / "view-run.png")


def campaign_screenshot(directory: Path) -> None:
    _wmr("view", str(directory))
    with Page.open(directory / "report.html", width=WIDTH, height=HEIGHT) as page:
        page.evaluate(
            "(() => { const s = document.querySelector('select'); s.value = 'expect-failed';"
            " s.dispatchEvent(new Event('change'));"
            " const th = [...document.querySelectorAll('#runs th')]"
            ".find(h => h.textContent.startsWith('max_constraint_violation'));"
            " th.click(); th.click();"
            " document.querySelector('h2:nth-of-type(3)').scrollIntoView(); })()"
        )
        assert page.problems() == []
        page.screenshot(IMAGES / "view-campaign.png")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--campaign", type=Path, help="an existing case2-headings directory")
    parser.add_argument("--only", choices=("run", "campaign"), help="one screenshot alone")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        if args.only != "campaign":
            run_screenshot(Path(scratch))
        if args.only == "run":
            print(IMAGES / "view-run.png")
            return
        campaign = args.campaign
        if campaign is None:
            campaign = Path(scratch) / "case2-headings"
            subprocess.run(
                [*WMR, "sweep", "missions/campaigns/case2-headings.yaml", "--out", str(campaign)],
                cwd=ROOT,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )  # exit 1: its expect is not met, which the report shows
        campaign_screenshot(campaign)
    for name in ("view-run.png", "view-campaign.png"):
        print(IMAGES / name)


if __name__ == "__main__":
    main()
