"""``wmr-mission falsify``: search a campaign's axes for failing runs (docs/falsification.md)."""
