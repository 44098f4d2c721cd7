"""Studies: series of discrete runs that differ by a shape parameter, run on Dask, resumed
across interruptions, summarised and reported (seeds 002 and 003's shape series)."""
