"""What a contact solver carries from one step to the next (soft_step.py's warm start):
each contact's key (its two spheres' identities, or its sphere's and face's) and the force
it carried, in a row of the sphere it belongs to: of a pair, the sphere with the smaller
identity; of a face, its sphere. A contact finds last step's force among at most
CONTACTS_PER_SPHERE keys of one row: no sort and no hash table, and the slots fill in the
order the contacts come, so a run is reproducible.

Kept by the Simulation beside the spheres, row for row; emptied on a reset. A spawn or a
remove moves each kept sphere's row with it (carried_memory); a key names spheres, not
places, so no pair's force is handed to another."""
import numba
import numpy as np

# Slots a row: one cache line of keys. A sphere in a dense pile owns about half its ~6-12
# pairs and its faces; a step with more starts the rest from no force.
CONTACTS_PER_SPHERE = 8


def contact_memory(count):
    """(keys (count, CONTACTS_PER_SPHERE) int64, forces (count, CONTACTS_PER_SPHERE, 4)
    float64: normal N, friction (3) N; held (count,) int64: the slots of each row in use),
    for `count` spheres, empty."""
    return (np.zeros((count, CONTACTS_PER_SPHERE), dtype=np.int64),
            np.zeros((count, CONTACTS_PER_SPHERE, 4)), np.zeros(count, dtype=np.int64))


def carried_memory(memory, old_identity, new_identity):
    """memory (contact_memory's triple, its rows the spheres of old_identity (n,) int64) for
    the spheres of new_identity: a sphere in both keeps its row, a new one starts empty."""
    carried = contact_memory(new_identity.size)
    if memory is None or memory[0].shape[0] != old_identity.size or old_identity.size == 0:
        return carried
    order = np.argsort(old_identity)
    place = np.minimum(np.searchsorted(old_identity[order], new_identity),
                       old_identity.size - 1)
    old_row = order[place]
    kept = np.flatnonzero(old_identity[old_row] == new_identity)
    for new, old in zip(carried, memory):
        new[kept] = old[old_row[kept]]
    return carried


@numba.njit(error_model='numpy', inline='always')
def remembered_slot(memory_keys, memory_held, home, key):
    """The slot of row `home` holding `key` (int64), or -1: a scan of the row's held slots
    without branches (a row is one cache line)."""
    slot = -1
    for k in range(memory_held[home]):
        slot = k if memory_keys[home, k] == key else slot
    return slot


@numba.njit(error_model='numpy')
def matched(keys, homes, memory_keys, memory_held):
    """How many of the contacts (keys (m,), each in row homes (m,)) the memory holds: the
    warm start's matching alone, for benchmarks/contact_stages.py."""
    found = 0
    for c in range(keys.size):
        found += remembered_slot(memory_keys, memory_held, homes[c], keys[c]) >= 0
    return found
