"""`backend: cuda`: the step on one NVIDIA GPU, compiled by numba-cuda from the same
per-sphere functions the CPU step inlines (physics/kernels/, physics/stepper.py's
_integrate, _face_mark and sphere_faces): no second copy of any effect, integrator or face
rule.

- kernels.py: the kernel of one scene configuration, composed as the CPU loop is (the
  scene's choices are compile-time constants).
- device.py: DeviceState, the spheres' arrays on the GPU and what the host has of them.

numba-cuda is an optional extra (`pip install pool_sim[cuda]`): nothing here is imported
unless a scene asks for `backend: cuda`. NUMBA_ENABLE_CUDASIM=1 runs the kernels in
numba's CUDA simulator, on the CPU (what the tests do on a machine without a GPU).
"""
import math
import os

import numpy as np

BACKENDS = ('cpu', 'cuda')
THREADS_PER_BLOCK = 128
_COMPILED = {}  # kernel function -> it compiled by cuda.jit, once per process
# What a refusal for want of numba-cuda tells the user to run (the pin the tests run).
INSTALL_COMMAND = 'pip install numba-cuda[cu13]==0.30.4'


def load_cuda():
    """numba.cuda, imported. numba-cuda 0.30.4 still names np.row_stack at import, which
    numpy 2.5 removed: np.vstack is what it was."""
    if not hasattr(np, 'row_stack'):
        np.row_stack = np.vstack
    from numba import cuda
    return cuda


def simulated():
    """Whether numba's CUDA simulator stands in for a GPU (NUMBA_ENABLE_CUDASIM=1)."""
    return os.environ.get('NUMBA_ENABLE_CUDASIM', '0') not in ('', '0')


def unavailable():
    """Why `backend: cuda` cannot run in this process (a sentence), or None if it can."""
    try:
        cuda = load_cuda()
    except ImportError as error:
        return f'numba-cuda is not installed ({error}): {INSTALL_COMMAND}'
    if simulated():
        return None
    try:
        if cuda.is_available():
            return None
    except Exception as error:  # noqa: BLE001 (any driver failure is a reason to refuse)
        return f'no usable CUDA device: {error}'
    return ('no CUDA device is present (numba.cuda.is_available() is False: no NVIDIA '
            'driver, or no GPU)')


def blocks_for(count):
    """Blocks of THREADS_PER_BLOCK threads that cover count items (at least one)."""
    return max(1, math.ceil(count / THREADS_PER_BLOCK))


def grid_for(count):
    """(blocks, threads): a launch of one thread an item over count items."""
    return blocks_for(count), THREADS_PER_BLOCK


def compiled(kernels):
    """{name: kernel}: the kernel functions compiled by cuda.jit, each once per process
    (every DeviceDetect, DeviceRows and DeviceSolve shares them)."""
    cuda = load_cuda()
    for kernel in kernels:
        if kernel not in _COMPILED:
            _COMPILED[kernel] = cuda.jit(kernel)
    return {kernel.__name__: _COMPILED[kernel] for kernel in kernels}
