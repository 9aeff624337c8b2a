"""Per-sphere compiled functions: scalar in, scalar out, plain namedtuples of floats and
bools (layout.py), no Python objects, so that numba inlines them into the step's loop (and
numba-cuda could compile them for a GPU)."""
