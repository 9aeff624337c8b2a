"""DeviceOrder: the orders the soft step sweeps its contacts in, made on the GPU
(order_kernels.py): colour() colours the contacts, support() makes the support sweep's
contacts, bottom up and wave by wave, and its floor contacts.

colour() colours greedily in colouring.colour_priority's order, not in the order the
contacts come as the CPU does (colouring.py says why): the same colouring as
colouring.colour_by_priority, to the bit, but not the CPU's, so a GPU step sweeps its
contacts in another order than the CPU's step (docs/gpu.md: by how much that differs).
support() is the CPU's support order (soft_step._support_order, then layers.sweep_waves),
to the bit.
"""
import numpy as np

from ..contacts.colouring import COLOURS
from . import compiled, grid_for, load_cuda
from .device_detect import SortLibrary
from .order_kernels import KERNELS


class DeviceOrder:
    """colour() and support() on device arrays."""

    def __init__(self, library=None):
        self.cuda = load_cuda()
        self.kernels = compiled(KERNELS)
        self.library = library or SortLibrary(self.cuda)
        self.rounds = {}  # the rounds the last colour() and support() took, for the tables

    def incidence(self, ends, rows):
        """(incident (2 m,) int64: the entries 2 c + j of items c with end j, by row, each
        row's in order; start (rows + 1,): where each row's entries begin) of ends (m, 2)
        whose ends are rows 0..rows - 1 (and any row past them, whose entries come last)."""
        keys = self.cuda.device_array(2 * ends.shape[0], dtype=np.int64)
        self.kernels['incidence_keys_kernel'][grid_for(keys.size)](ends, keys)
        incident = self.library.stable_order(keys)
        return incident, self.library.starts(keys, incident, rows)

    def _rounds(self, name, count, before, after=()):
        """Launches kernel `name` (arguments: before, the waiting count, after) over count
        items, round after round, until none is left waiting; returns the rounds. Each
        round settles at least the first item still waiting, so count + 1 rounds are a
        bound only a fault can reach."""
        waiting = self.cuda.to_device(np.zeros(1, dtype=np.int64))
        zero = np.zeros(1, dtype=np.int64)
        for taken in range(1, count + 2):
            waiting.copy_to_device(zero)
            self.kernels[name][grid_for(count)](*before, waiting, *after)
            if int(waiting.copy_to_host()[0]) == 0:
                return taken
        raise RuntimeError(f'{name}: items still waiting after {count + 1} rounds')

    def colour(self, ends, ground):
        """(slot (m,) int64 on the device: each contact's place in the sweep, colour by
        colour; colour_start (COLOURS + 1,) int64 on the host) of the contacts ends (m, 2)
        between member rows, the ground's row being `ground`."""
        cuda, total = self.cuda, ends.shape[0]
        incident, start = self.incidence(ends, ground)
        colour = cuda.to_device(np.full(total, -1, dtype=np.int64))
        self.rounds['colour'] = self._rounds('colour_round_kernel', total,
                                             (ends, ground, incident, start, colour))
        by_colour = self.library.stable_order(colour)
        slot = cuda.device_array(total, dtype=np.int64)
        self.kernels['slot_kernel'][grid_for(total)](by_colour, slot)
        colour_start = self.library.starts(colour, by_colour, COLOURS).copy_to_host()
        return slot, colour_start

    def support(self, rows, ends, found, faces_of, slot, sphere, old_position, radius):
        """{ends, facts, wave_bounds, floor_member, floor_gap}: device arrays, the support
        sweep's contacts wave by wave as DeviceSolve sweeps them (soft_step._support_order's
        ends and facts in layers.sweep_waves' order, and its bounds; its floor contacts),
        from the filled rows, the contacts' ends (the found pairs first), faces_of, slot
        and sphere (DeviceRows') and the step's start old_position (3, n) and radius (n,)."""
        cuda, kernels, library = self.cuda, self.kernels, self.library
        faces, members = faces_of.shape[0], sphere.shape[0]
        flags = cuda.device_array(faces, dtype=np.int64)
        kernels['floor_flags_kernel'][grid_for(faces)](faces_of, flags)
        offsets, floors = library.offsets(flags)
        floor_member = cuda.device_array(floors, dtype=np.int64)
        floor_gap = cuda.device_array(floors)
        kernels['floor_place_kernel'][grid_for(faces)](faces_of, flags, offsets, rows, slot,
                                                       found, floor_member, floor_gap)
        made = {'floor_member': floor_member, 'floor_gap': floor_gap}
        if floors == 0:  # nothing is held up: spheres falling through air and water
            return {**made, 'ends': cuda.device_array((0, 2), dtype=np.int64),
                    'facts': cuda.device_array((0, 4)),
                    'wave_bounds': cuda.to_device(np.zeros(1, dtype=np.int64))}
        pair_ends = ends[:found]
        z, member_radius = cuda.device_array(members), cuda.device_array(members)
        extent = cuda.to_device(np.array([np.inf, -np.inf, np.inf]))
        kernels['heights_kernel'][grid_for(members)](sphere, old_position, radius, z,
                                                     member_radius, extent)
        layer = cuda.device_array(found, dtype=np.int64)
        kernels['layer_kernel'][grid_for(found)](pair_ends, z, extent, layer)
        bottom_up = library.stable_order(layer)
        flags = cuda.device_array(found, dtype=np.int64)
        kernels['bearing_flags_kernel'][grid_for(found)](rows, slot, bottom_up, flags)
        offsets, bearing = library.offsets(flags)
        bearing_ends = cuda.device_array((bearing, 2), dtype=np.int64)
        facts = cuda.device_array((bearing, 4))
        kernels['bearing_place_kernel'][grid_for(found)](rows, slot, pair_ends, bottom_up,
                                                         flags, offsets, bearing_ends, facts)
        return {**made, **self._waves(bearing_ends, facts, members)}

    def _waves(self, ends, facts, members):
        """{ends, facts, wave_bounds}: the support contacts (ends (b, 2), facts (b, 4)) in
        layers.sweep_waves' order, and where each wave begins, then the end."""
        cuda, kernels, library, bearing = self.cuda, self.kernels, self.library, ends.shape[0]
        incident, start = self.incidence(ends, members)
        wave = cuda.to_device(np.full(bearing, -1, dtype=np.int64))
        deepest = cuda.to_device(np.full(1, -1, dtype=np.int64))
        self.rounds['waves'] = self._rounds('wave_round_kernel', bearing,
                                            (ends, incident, start, wave), (deepest,))
        by_wave = library.stable_order(wave)
        wave_bounds = library.starts(wave, by_wave, int(deepest.copy_to_host()[0]) + 1)
        in_waves = cuda.device_array((bearing, 2), dtype=np.int64)
        facts_in_waves = cuda.device_array((bearing, 4))
        kernels['gather_kernel'][grid_for(bearing)](by_wave, ends, facts, in_waves,
                                                    facts_in_waves)
        return {'ends': in_waves, 'facts': facts_in_waves, 'wave_bounds': wave_bounds}
