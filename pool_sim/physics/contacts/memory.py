"""What a contact solver carries from one step to the next (soft_step.py's warm start):
each contact's key (its two spheres' identities, or its sphere's and face's) and the
force it carried, sorted by key. Kept by the Simulation beside the spheres, emptied on a
reset; a spawn or a remove keeps it (keys name spheres, not places)."""
import numpy as np

# Room for this many contacts a sphere (pairs and faces): a dense pile has ~6 pairs and a
# few faces per sphere; a step with more remembers the lowest keys, and the rest start
# from no force.
CONTACTS_PER_SPHERE = 8


def memory_capacity(count):
    """Contacts remembered for `count` spheres."""
    return CONTACTS_PER_SPHERE * count + 16 if count >= 2 else 0


def contact_memory(count, previous=None):
    """(keys (capacity,) int64, forces (capacity, 4) float64: normal N, friction (3) N,
    remembered (1,) int64) for `count` spheres, empty, or holding what `previous` (such a
    triple) held, as much of it as fits (its lowest keys)."""
    capacity = memory_capacity(count)
    keys = np.zeros(capacity, dtype=np.int64)
    forces = np.zeros((capacity, 4))
    remembered = np.zeros(1, dtype=np.int64)
    if previous is not None:
        kept = min(int(previous[2][0]), capacity)
        keys[:kept], forces[:kept] = previous[0][:kept], previous[1][:kept]
        remembered[0] = kept
    return keys, forces, remembered
