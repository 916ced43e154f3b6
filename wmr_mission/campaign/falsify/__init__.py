"""``wmr-mission falsify``: search a campaign's axes for failing runs (docs/falsification.md).

The methods' names live here, the one place the command line, the Python API
and the search read them from, without importing the search itself.
"""

from typing import Final

__all__ = ["DEFAULT_METHOD", "METHODS"]

METHODS: Final = ("gp", "cmaes", "random")
"""The search methods (:func:`wmr_mission.campaign.falsify.search.make_method`)."""

DEFAULT_METHOD: Final = "gp"
"""The method ``falsify`` uses unless told another."""
