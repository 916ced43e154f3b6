"""Looking at results: a run's or a campaign's directory as an offline HTML
report (``view``) or as MCAP and Parquet files (``export``)."""
