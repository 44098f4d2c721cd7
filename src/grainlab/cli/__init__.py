"""The ``grainlab`` command line: one command per lab test and per report."""
