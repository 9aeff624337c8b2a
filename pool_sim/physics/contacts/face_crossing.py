"""The smooth step's velocity change that a contact solver keeps for a sphere whose smooth
path crossed a face of the pool (soft_step.py spreads that change over its substeps).

The smooth step knows no faces: a sphere it takes past the floor feels the forces of
where it cannot be. Where the water's surface is at the floor (a dry pool), a sphere of
1e-6 kg taken 3 cm past it felt the water's buoyancy there and turned from 6 m/s down to
41.7 m/s up within one step, a change no contact takes back, since it points away from
the floor. This keeps, along the face's normal, the speed the sphere reached the face at
(kernels/faces.py's impact_speed, as the per-sphere face rule takes it), whichever way
the smooth step's end velocity points: the per-sphere rule keeps an end velocity that
leaves the face, and so would keep this one.
"""
import numba

from ..kernels.faces import impact_speed


@numba.njit(error_model='numpy')
def bound_face_crossings(change, faces_of, sphere, old_position, old_velocity, position,
                         velocity, radius, faces, substeps, dt):
    """change (rows, 4) m/s per substep, the smooth step's velocity change of each member
    row, rewritten along the normal of each face of faces_of ((f, 2): row, face 0-5: low
    x, y, z, high) that the member's smooth path crossed this step (apart at the start,
    past it at the end): it ends approaching the face at the speed it reached it at.
    old_*, position, velocity: the step's start and the smooth step's end; faces (6,) m:
    the pool's low then high corner; radius (n,) m."""
    bound_crossing_range(change, faces_of, sphere, old_position, old_velocity, position,
                         velocity, radius, faces, substeps, dt, 0, faces_of.shape[0], 1)


@numba.njit(error_model='numpy')
def bound_crossing_range(change, faces_of, sphere, old_position, old_velocity, position,
                         velocity, radius, faces, substeps, dt, start, stop, step):
    """bound_face_crossings for face contacts start, start + step, ... below stop (a GPU
    thread takes a member's, which are in a row: a member's faces share its change)."""
    for f in range(start, stop, step):
        k, face = faces_of[f, 0], faces_of[f, 1]
        i, axis = sphere[k], face % 3
        inward = 1.0 if face < 3 else -1.0  # the face's normal, into the pool
        before = inward * (old_position[axis, i] - faces[face]) - radius[i]
        past = radius[i] - inward * (position[axis, i] - faces[face])
        if before < 0.0 or past <= 0.0:
            continue  # touching from the start, or not reaching the face: nothing crossed
        reached = impact_speed(-inward * old_velocity[axis, i], -inward * velocity[axis, i],
                               before, past, dt)
        change[k, axis] = (-inward * reached - old_velocity[axis, i]) / substeps
