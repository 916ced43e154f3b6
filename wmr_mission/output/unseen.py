"""Work matplotlib does for a figure and never draws, left out when a file is written.

The same drawing, fewer artists and measurements:

* matplotlib makes a tick (three lines and two texts) for every location its
  default locator gives, and draws only those inside the view; the locator
  gives one more beyond each end where the view ends between two ticks.
  About a third of a run directory's ticks were made and never drawn.
* To place an axis label matplotlib measures every tick label of its axis,
  a second time (the drawing measures them too), even when the label is
  empty and draws nothing.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.ticker import AutoLocator

if TYPE_CHECKING:
    from matplotlib.figure import Figure

# The slack matplotlib allows a tick at the view's ends (transforms._interval_contains_close).
_ENDS_RTOL = 1e-10


class ShownTicks(AutoLocator):
    """The default locator's ticks, less those it places outside the view."""

    def __call__(self) -> np.ndarray:  # type: ignore[override]  # an array, as its parent gives
        locations = np.asarray(super().__call__())
        assert self.axis is not None
        low, high = sorted(self.axis.get_view_interval())
        slack = _ENDS_RTOL * (high - low)
        shown = locations[(locations >= low - slack) & (locations <= high + slack)]
        # The formatter picks the labels' digits from the locations: with
        # fewer than two it looks at the view's ends instead, so keep them all.
        return shown if shown.size >= 2 else locations


def skip_unseen(fig: Figure) -> None:
    """Give each linear axis of ``fig`` still on the default locator the same
    ticks without those outside the view, and leave each empty axis label
    where it is instead of placing it."""
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if (
                axis.isDefault_majloc
                and type(axis.get_major_locator()) is AutoLocator
                and axis.get_scale() == "linear"
            ):
                axis.set_major_locator(ShownTicks())
            if not axis.label.get_text():
                axis.set_label_coords(0.0, 0.0)  # anywhere: it draws nothing
