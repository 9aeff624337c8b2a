"""DeviceDetect: contact detection (contacts/detection.py's detect_contacts) on the GPU, from
the spheres' arrays there, through detect_kernels.py; its result is what the CPU's is (the
same pairs in the same order, the same facts; to the bit in numba's simulator).

The sort by cell and the running sum of the rows' counts come from a library, not from code
of ours: CuPy's stable sort and cumulative sum (thrust and CUB) on a GPU, numpy's in numba's
simulator, where CuPy cannot run. CuPy takes numba's device arrays as they are (the CUDA
array interface): nothing leaves the GPU.
"""
import math

import numpy as np

from . import compiled, grid_for, load_cuda, simulated
from .detect_kernels import KERNELS
from ..contacts.detection import STATE_COLUMNS

# What a refusal for want of CuPy tells the user to run.
CUPY_COMMAND = 'pip install cupy-cuda13x'


class SortLibrary:
    """The library calls detection needs on device arrays: stable_order (the indices that
    sort int64 keys, equal keys in their order), starts (where each of `buckets` keys begins
    among the sorted keys) and offsets (an exclusive running sum)."""

    def __init__(self, cuda):
        self.cuda = cuda
        self.cupy = None
        if not simulated():
            try:
                import cupy
            except ImportError as error:
                raise ImportError(f'detection on the GPU sorts with CuPy ({error}): '
                                  f'{CUPY_COMMAND}') from error
            self.cupy = cupy

    def _cupy(self, array):
        """A device array as CuPy's, once numba's launches before it are done: numba
        launches on the legacy default stream, CuPy on its current one, which need not be
        the same (CUPY_CUDA_PER_THREAD_DEFAULT_STREAM)."""
        self.cuda.synchronize()
        return self.cupy.asarray(array)

    def _numba(self, array):
        """A CuPy array as numba's, once CuPy's work on it is done."""
        self.cupy.cuda.get_current_stream().synchronize()
        return self.cuda.as_cuda_array(array)

    def stable_order(self, keys):
        if self.cupy is None:
            return self.cuda.to_device(np.argsort(keys.copy_to_host(), kind='stable'))
        return self._numba(self.cupy.argsort(self._cupy(keys)))

    def starts(self, keys, order, buckets):
        if self.cupy is None:
            ordered = keys.copy_to_host()[order.copy_to_host()]
            return self.cuda.to_device(np.searchsorted(ordered, np.arange(buckets + 1)))
        cupy = self.cupy
        ordered = self._cupy(keys)[self._cupy(order)]
        return self._numba(cupy.searchsorted(
            ordered, cupy.arange(buckets + 1, dtype=ordered.dtype)).astype(cupy.int64))

    def offsets(self, counts):
        """(offsets (n + 1,) int64 on the device: where each of the n items' shares begins,
        and, last, where they all end (a running sum of counts (n,) int64 from 0); that end,
        an int)."""
        if self.cupy is None:
            offsets = np.concatenate(([0], np.cumsum(counts.copy_to_host()))).astype(np.int64)
            return self.cuda.to_device(offsets), int(offsets[-1])
        cupy = self.cupy
        offsets = cupy.concatenate((cupy.zeros(1, dtype=cupy.int64),
                                    cupy.cumsum(self._cupy(counts))))
        return self._numba(offsets), int(offsets[-1])


class DeviceDetect:
    """detect_contacts on the GPU. detect() takes the step's device arrays and returns the
    Contacts' arrays on the device, by name."""

    def __init__(self, library=None):
        self.cuda = load_cuda()
        self.library = library or SortLibrary(self.cuda)
        self.kernels = compiled(KERNELS)

    def detect(self, old_position, old_velocity, position, velocity, radius, dt):
        """{pairs (2, m) int64, facts (6, m): normal (3), excess, added, closing; order (n,)
        int64; state (n, STATE_COLUMNS)} as detect_contacts makes them (Contacts), from
        (3, n) device arrays of the step's start and end and radius (n,)."""
        cuda, kernels, count = self.cuda, self.kernels, radius.shape[0]
        spheres = grid_for(count)
        centre, reach = cuda.device_array((3, count)), cuda.device_array(count)
        smallest = cuda.to_device(np.array([math.inf]))
        kernels['bounds_kernel'][spheres](old_position, position, radius, centre, reach, smallest)
        level, top = cuda.device_array(count, np.int64), cuda.to_device(np.zeros(1, np.int64))
        kernels['levels_kernel'][spheres](reach, smallest, level, top)
        levels = int(top.copy_to_host()[0]) + 1
        members = cuda.to_device(np.zeros(levels, np.int64))
        largest = cuda.to_device(np.zeros(levels))
        low = cuda.to_device(np.full((levels, 3), math.inf))
        high = cuda.to_device(np.full((levels, 3), -math.inf))
        kernels['extents_kernel'][spheres](centre, reach, level, members, largest, low, high)
        size, cells = cuda.to_device(np.zeros(levels)), cuda.to_device(np.ones((levels, 3),
                                                                               np.int64))
        first_cell = cuda.to_device(np.zeros(levels + 1, np.int64))
        kernels['grids_kernel'][1, 1](members, largest, low, high, size, cells, first_cell)
        where, home = cuda.device_array((3, count), np.int64), cuda.device_array(count, np.int64)
        kernels['homes_kernel'][spheres](centre, level, low, size, cells, first_cell, where, home)
        order = self.library.stable_order(home)
        start = self.library.starts(home, order, int(first_cell.copy_to_host()[levels]))
        sorted_bound = cuda.device_array((count, 4))
        sorted_cell = cuda.device_array((count, 4), np.int64)
        state = cuda.device_array((count, STATE_COLUMNS))
        kernels['place_kernel'][spheres](old_position, old_velocity, position, velocity,
                                         radius, centre, reach, level, where, order,
                                         sorted_bound, sorted_cell, state)
        grids = (sorted_cell, members, cells, first_cell, start, sorted_bound, largest, low,
                 size)
        counts = cuda.device_array(count, np.int64)
        kernels['count_kernel'][spheres](*grids, counts, cuda.device_array((2, 0), np.int64))
        offsets, total = self.library.offsets(counts)  # where each row's pairs begin
        candidates = cuda.device_array((2, total), np.int64)
        differ = cuda.to_device(np.zeros(1, np.int64))
        kernels['write_kernel'][spheres](*grids, counts, offsets, candidates, differ)
        if int(differ.copy_to_host()[0]):  # rows with pairs left unwritten: unsafe to read
            raise RuntimeError('detection on the GPU: the write pass found other pairs than '
                               'the count pass (differently rounded comparisons)')
        facts = cuda.device_array((6, total))
        kernels['narrow_kernel'][grid_for(total)](state, candidates, dt, facts)
        return {'pairs': candidates, 'facts': facts, 'order': order, 'state': state}
