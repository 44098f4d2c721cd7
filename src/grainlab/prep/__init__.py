"""Making specimens: regular lattices, packings read from files, loose random samples, dense
deposited sphere packings and the shapes inscribed in them."""

from grainlab.prep.packing_files import read_packing, write_packing
from grainlab.prep.regular_packings import named_packing, packing_names

__all__ = ["named_packing", "packing_names", "read_packing", "write_packing"]
