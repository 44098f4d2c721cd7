"""The laboratory: load paths, presets, test protocols and their runs (the test-result format
itself lives in :mod:`grainlab.result`)."""
