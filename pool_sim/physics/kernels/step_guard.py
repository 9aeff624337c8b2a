"""The step guard's two halves, for every pass that can leave a sphere non-finite: the
test, and putting the sphere back where its step began, at rest."""
from . import compiled


@compiled
def finite(state):
    """Whether every component of state (x, y, z, vx, vy, vz) is finite: v * 0 is 0 for a
    finite v and NaN otherwise, so one comparison and no branch (a loop stays vectorised)."""
    return (state[0] * 0.0 + state[1] * 0.0 + state[2] * 0.0 + state[3] * 0.0
            + state[4] * 0.0 + state[5] * 0.0) == 0.0


@compiled
def put_back(position, velocity, start_position, failed, i):
    """Sphere i back where its step began (start_position (3, n) m) and at rest, in position
    and velocity (3, n); flagged in failed (n,)."""
    for axis in range(3):
        position[axis, i] = start_position[axis, i]
        velocity[axis, i] = 0.0
    failed[i] = 1
