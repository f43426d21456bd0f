"""numba kernels: flat float64/int64 arrays in, flat arrays out, no Python objects.

Kernels assume validated input; the Python layer above validates and converts.
Import kernel modules lazily (first call compiles, ``cache=True`` keeps the result).
"""
