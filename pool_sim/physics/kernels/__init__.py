"""Per-sphere compiled functions: scalar in, scalar out, plain namedtuples of floats and
bools (layout.py), no Python objects, so that numba inlines them into the step's loop (and
numba-cuda could compile them for a GPU)."""
import numba


def compiled(function):
    """A per-sphere scalar function, compiled by numba and inlined wherever it is called, so
    the step a scene composes from these is one loop body the compiler can specialise."""
    return numba.njit(forceinline=True, error_model='numpy')(function)
