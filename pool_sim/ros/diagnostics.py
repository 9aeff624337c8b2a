"""What the node warns about on its own: an integrator unstable at the configured rate, and
spheres the step guard put back (with the likely cause)."""
import math
import time

from pool_sim.physics.spheres import named_few
from pool_sim.physics.stability import stable_at, stable_step_bound
from pool_sim.ros.services import THROTTLE_S


class Diagnostics:
    """Warnings about the physics of `node` (its scene and simulation), in its log."""

    def __init__(self, node):
        self.node = node
        self.next_recovery_log_wall = 0.0  # monotonic s

    def warn_if_unstable(self, indices=None):
        """Warn when the integrator is unstable at the configured rate for the scene's
        stiffest sphere (indices None: at start-up) or for the spheres `indices` just
        changed."""
        scene, simulation = self.node.scene, self.node.simulation
        if indices is not None and stable_at(scene, simulation.max_step,
                                             spheres=simulation.spheres, indices=indices):
            return  # one look at the step map; the bound (a bisection) only for the warning
        if indices is None:
            bound, what = stable_step_bound(scene), 'this scene: its stiffest sphere'
        else:
            bound = stable_step_bound(scene, spheres=simulation.spheres, indices=indices)
            names = named_few([simulation.spheres.names[i] for i in indices])
            what = f'{names} as changed: it'
        if simulation.max_step > bound:
            self.node.get_logger().warning(
                f'{scene["integrator"]} is unstable at {scene["physics_rate_hz"]:g} Hz '
                f'for {what} needs a step under {bound * 1e3:.3g} ms '
                f'({1.0 / bound if bound > 0 else math.inf:.4g} Hz or more); '
                'linearly_implicit_euler is stable at any rate')

    def report_recovered(self):
        """Name the spheres the step guard put back since the last call, and the likely
        cause; at most one line a THROTTLE_S (the likely cause costs a bisection)."""
        simulation = self.node.simulation
        recovered = simulation.take_recovered()
        if recovered and time.monotonic() >= self.next_recovery_log_wall:
            self.next_recovery_log_wall = time.monotonic() + THROTTLE_S
            names = named_few([simulation.spheres.names[i] for i in recovered])
            self.node.get_logger().error(
                f'a step would have left {names} non-finite or outside the pool: put back at '
                f'rest where the step began; likely cause: '
                f'{simulation.likely_cause(recovered[0])}')
