"""The GPU step of one scene configuration, from the CPU step's own per-sphere functions.

One thread per sphere. Without collisions the spheres are independent, so one launch takes
every step of a call and a sphere's state stays in registers between its steps: read once,
written once (the smooth step, _integrate; its faces and the step guard, sphere_faces; the
same functions, in the same order, as physics/stepper.py's passes). The scene's choices are
compile-time constants, as on the CPU: what it does not list is not in the kernel.

The loop is the scalar one (Listed.scalar): a thread skips by a branch the work its sphere
does not need (the table look-ups of a sphere off the surface), which a vectorised CPU loop
could not.

With collisions a step is three launches, as physics/stepper.py's run_steps has three
passes: smooth_source's (the smooth step, each sphere's face mark), the collision pass
(device_collisions.py), and faces_source's (the faces and the step guard of the spheres
still marked, _faces_and_guard's).
"""
from ..kernels.layout import body_of, env_of
from ..kernels.step_guard import put_back as put_back_sphere
from ..stepper import _face_mark, _integrate, sphere_faces
from . import load_cuda

# A global, not a local: numba's CUDA simulator runs a kernel with each thread's own
# `cuda` swapped into the kernel's globals.
cuda = load_cuda()


def advance_source(integrator_code, listed, has_contact, has_friction):
    """The kernel of one configuration as a Python function (cuda.jit compiles it; the
    tests compile it to PTX without a device). Arguments: position, velocity (3, n) m and
    m/s, in place; properties, the spheres' arrays (layout.properties_of); environment
    (12,) and wave_table as env_of takes them; pool (6,) m (corner_min, corner_max);
    contact (4,) (ContactParameters' fields); failed (n,) uint8, set for a sphere the step
    guard put back; put_back (1,) int64, += how many times it did; steps; dt s."""
    def advance(position, velocity, properties, environment, wave_table, pool, contact, failed,
                put_back, steps, dt):
        i = cuda.grid(1)
        if i >= position.shape[1]:
            return
        env = env_of(environment, wave_table)
        body = body_of(properties, i)
        faces = (pool[0], pool[1], pool[2], pool[3], pool[4], pool[5])
        contact_parameters = (contact[0], contact[1], contact[2], contact[3])
        start = (position[0, i], position[1, i], position[2, i])
        start_velocity = (velocity[0, i], velocity[1, i], velocity[2, i])
        backs = 0
        for _ in range(steps):
            s = _integrate(integrator_code, listed, env, body, start, start_velocity, dt)
            if _face_mark(has_contact, faces, body.radius, s) != 0:
                old = (start[0], start[1], start[2],
                       start_velocity[0], start_velocity[1], start_velocity[2])
                s, overflow = sphere_faces(listed, has_contact, has_friction, env, faces,
                                           contact_parameters, body, old, s, dt)
                if overflow:  # the step guard: back where the step began, at rest
                    s = (start[0], start[1], start[2], 0.0, 0.0, 0.0)
                    backs += 1
            start, start_velocity = (s[0], s[1], s[2]), (s[3], s[4], s[5])
        position[0, i], position[1, i], position[2, i] = start
        velocity[0, i], velocity[1, i], velocity[2, i] = start_velocity
        if backs > 0:
            failed[i] = 1
            cuda.atomic.add(put_back, 0, backs)  # integers: the same sum in any order

    return advance



def smooth_source(integrator_code, listed, has_contact):
    """The smooth step's kernel of one configuration (run_steps' first pass): one step of
    dt s from old_position, old_velocity (3, n) into position, velocity; flagged (n,)
    uint8, each sphere's face mark (_face_mark: on or past a face, or not finite).
    properties, environment, wave_table, pool: as advance_source's kernel takes them."""
    def smooth(old_position, old_velocity, position, velocity, properties, environment,
               wave_table, pool, flagged, dt):
        i = cuda.grid(1)
        if i >= position.shape[1]:
            return
        body = body_of(properties, i)
        faces = (pool[0], pool[1], pool[2], pool[3], pool[4], pool[5])
        s = _integrate(integrator_code, listed, env_of(environment, wave_table), body,
                       (old_position[0, i], old_position[1, i], old_position[2, i]),
                       (old_velocity[0, i], old_velocity[1, i], old_velocity[2, i]), dt)
        position[0, i], position[1, i], position[2, i] = s[0], s[1], s[2]
        velocity[0, i], velocity[1, i], velocity[2, i] = s[3], s[4], s[5]
        flagged[i] = _face_mark(has_contact, faces, body.radius, s)

    return smooth


def faces_source(listed, has_contact, has_friction):
    """The faces' kernel of one configuration (run_steps' _faces_and_guard): each sphere
    still flagged (n,) takes sphere_faces on its step from old_* to position, velocity,
    then the step guard (failed (n,) uint8 set and put_back[0] += 1 for a sphere put
    back). contact (4,): ContactParameters' fields; the rest as smooth_source's."""
    def faces_pass(old_position, old_velocity, position, velocity, properties, environment,
                   wave_table, pool, contact, flagged, failed, put_back, dt):
        i = cuda.grid(1)
        if i >= position.shape[1] or flagged[i] == 0:
            return
        old = (old_position[0, i], old_position[1, i], old_position[2, i],
               old_velocity[0, i], old_velocity[1, i], old_velocity[2, i])
        state = (position[0, i], position[1, i], position[2, i],
                 velocity[0, i], velocity[1, i], velocity[2, i])
        s, overflow = sphere_faces(listed, has_contact, has_friction,
                                   env_of(environment, wave_table),
                                   (pool[0], pool[1], pool[2], pool[3], pool[4], pool[5]),
                                   (contact[0], contact[1], contact[2], contact[3]),
                                   body_of(properties, i), old, state, dt)
        if overflow:
            put_back_sphere(position, velocity, old_position, failed, i)
            cuda.atomic.add(put_back, 0, 1)  # integers: the same sum in any order
        else:
            position[0, i], position[1, i], position[2, i] = s[0], s[1], s[2]
            velocity[0, i], velocity[1, i], velocity[2, i] = s[3], s[4], s[5]

    return faces_pass
