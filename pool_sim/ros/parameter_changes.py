"""Parameter changes: one request is one transaction, planned and checked once, then applied.

Every way in takes one path to the core: `ros2 param set`, rclpy's set_parameters and
set_parameters_atomically, a spawn or remove (sphere_names with the new spheres' keys), and
the world services ~/set_mass and ~/set_radius. A plan (parameter_plans.py) holds the
core's checked changes; applying it writes them without checking again, and the node's
parameter table shows the values the simulation now has.

rclpy calls three hooks per request: before its own type and range checks (integers for
doubles become doubles, a radius brings its following lift area along), to accept or refuse
the whole request (the plan is made), and after it stored the values (the plan is applied).
"""
import math

import numpy as np
from rcl_interfaces.msg import SetParametersResult
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter

from pool_sim.physics import InvalidInput
from pool_sim.physics.schema import SPHERE_KEYS
from pool_sim.physics.spheres import named_few, RADIUS_RANGE_M
from pool_sim.ros.parameter_plans import plan_request
from pool_sim.ros.parameters import (ARRAY_PREFIX, as_declared_types, describe, doubles,
                                     is_read_only, LIVE_SPHERE_KEYS, LOCKSTEP_KEYS, retable,
                                     sphere_parameters)
from pool_sim.ros.services import unknown_type_refusal


class ParameterChanges:
    """The parameter transactions of `node` (its lock, scene, simulation and parameter
    table); what follows a change is told to the clock, publishing, inputs, lockstep and
    diagnostics."""

    def __init__(self, node, clock, publishing, inputs, lockstep, diagnostics):
        self.node, self.clock, self.publishing = node, clock, publishing
        self.inputs, self.lockstep, self.diagnostics = inputs, lockstep, diagnostics
        self._accepted = None  # (the request's parameter list, its Plan), until applied
        self._following_lift_areas = set()  # names the first hook added to a request
        self.configure_lockstep()
        node.add_pre_set_parameters_callback(self._complete)
        node.add_on_set_parameters_callback(self._check)
        node.add_post_set_parameters_callback(self._apply)

    def configure_lockstep(self):
        scene = self.node.scene
        self.lockstep.configure(scene['lockstep'], scene['lockstep_inputs'],
                                scene['lockstep_timeout'])
        self.inputs.warn_future = scene['lockstep']

    # -- rclpy's three hooks -----------------------------------------------------------------

    def _complete(self, parameters):
        """Before rclpy's checks: integers for doubles become doubles, and a radius change
        brings the lift area along where the area follows the radius."""
        parameters = as_declared_types(parameters)
        given = {p.name for p in parameters}
        spheres = self.node.simulation.spheres
        extra = []
        for parameter in parameters:
            value = parameter.value
            # Only a radius of the right type and within its range brings an area along;
            # anything else is left for rclpy's and our checks to refuse, with their reason.
            if (self.node.per_sphere and parameter.name.endswith('.radius')
                    and parameter.type_ == Parameter.Type.DOUBLE
                    and RADIUS_RANGE_M[0] <= value <= RADIUS_RANGE_M[1]):
                sphere = parameter.name[:-len('.radius')]
                i = spheres.index.get(sphere)
                if (i is not None and spheres.lift_area_follows_radius[i]
                        and f'{sphere}.lift_area' not in given):
                    extra.append(Parameter(f'{sphere}.lift_area', value=math.pi * value * value))
            elif (not self.node.per_sphere and parameter.name == f'{ARRAY_PREFIX}radius'
                  and parameter.type_ == Parameter.Type.DOUBLE_ARRAY
                  and f'{ARRAY_PREFIX}lift_area' not in given
                  and 'sphere_names' not in given and len(value) == spheres.count):
                radius = np.clip(np.asarray(value, dtype=float), *RADIUS_RANGE_M)
                area = np.where(spheres.lift_area_follows_radius, math.pi * radius * radius,
                                spheres.lift_area)
                extra.append(Parameter(f'{ARRAY_PREFIX}lift_area', value=area.tolist()))
        # The parameter table shows them; the core's radius change moves a following area
        # itself, and setting it as given would stop it following.
        self._following_lift_areas = {parameter.name for parameter in extra}
        return parameters + extra

    def _check(self, parameters):
        """Accept or refuse the whole request: its plan, checked once."""
        with self.node.lock():
            try:
                self._accepted = (parameters, plan_request(self.node, parameters,
                                                           self._following_lift_areas))
            except InvalidInput as error:
                self._accepted = None
                return SetParametersResult(successful=False, reason=str(error))
            finally:
                self._following_lift_areas = set()  # this request's only
        return SetParametersResult(successful=True)

    def _apply(self, parameters):
        """rclpy stored the request: apply the plan accepted for it."""
        with self.node.lock():
            accepted, self._accepted = self._accepted, None
            if accepted is None or accepted[0] is not parameters:
                return
            plan = accepted[1]
            if plan.spheres is not None:
                self._change_spheres(plan.spheres)
            if plan.settings is not None:
                self.node.scene = plan.settings
            self.configure_lockstep()
            self._apply_live(plan.live)

    def _apply_live(self, live):
        touched = set()
        for _, change in live:
            self.node.simulation.apply_change(change)
            touched.add(change.index)
        if touched:
            self.diagnostics.warn_if_unstable(sorted(touched))

    # -- the world services' way in ----------------------------------------------------------

    def set_checked(self, live):
        """Apply [(sphere, CheckedChange)] of one key the core checked just now (~/set_mass,
        ~/set_radius), under the node's lock, and show the new values in the parameter
        table with one ParameterEvent, as a set_parameters request of them would: each name
        once, the key's entries in request order, then the lift areas that follow a radius.
        rclpy's set path (and any other hook on it) is not run: the core's check is the one
        check."""
        self._apply_live(live)
        spheres = self.node.simulation.spheres
        shown, areas = {}, {}
        for sphere, change in live:
            key, i = change.key, change.index
            if not self.node.per_sphere:
                shown[f'{ARRAY_PREFIX}{key}'] = doubles(getattr(spheres, key))
                if key == 'radius':  # it may follow the radius
                    areas[f'{ARRAY_PREFIX}lift_area'] = doubles(spheres.lift_area)
                continue
            shown[f'{sphere}.{key}'] = float(getattr(spheres, key)[i])
            if key == 'radius' and spheres.lift_area_follows_radius[i]:
                areas[f'{sphere}.lift_area'] = float(spheres.lift_area[i])
        retable(self.node, changed=list(shown.items()) + list(areas.items()))

    def show_initial_values(self, before):
        """After a reset: the parameters of what a live change had moved show the initial
        values again. before: {key: (n,) values} of the live keys before the reset. The
        table is written directly (the simulation is already back, and a lift area set back
        as if given would stop following its radius)."""
        spheres = self.node.simulation.spheres
        changed = []
        for key, values in before.items():
            initial = getattr(spheres, key)
            moved = np.flatnonzero(values != initial)
            if moved.size and self.node.per_sphere:
                changed += [(f'{spheres.names[i]}.{key}', float(initial[i])) for i in moved]
            elif moved.size:
                changed.append((f'{ARRAY_PREFIX}{key}', doubles(initial)))
        if changed:
            retable(self.node, changed=changed)

    # -- spawn and remove --------------------------------------------------------------------

    def _change_spheres(self, scene):
        """Spawn and remove: the simulation, the topics and the parameter table follow."""
        node = self.node
        before = node.simulation.spheres.names
        after = scene.sphere_names
        removed = [name for name in before if name not in set(after)]
        added = [name for name in after if name not in set(before)]
        node.simulation.change_spheres(scene)
        self.clock.spheres_changed()
        node.scene = scene
        self.inputs.follow_spheres(before, after)
        self.inputs.remove_spheres(removed)
        self.inputs.add_spheres(added)
        self.publishing.change_spheres(removed, added)
        if node.per_sphere:
            gone = [f'{name}.{key}' for name in removed for key in SPHERE_KEYS]
            new = [(name, value, describe(name, is_read_only(name)))
                   for name, value, _ in sphere_parameters(scene, True, names=added)]
            retable(node, removed=gone, declared=new)
        else:
            live = {key: getattr(node.simulation.spheres, key) for key in LIVE_SPHERE_KEYS}
            retable(node, declared=sphere_parameters(scene, False, live=live))
        self.publishing.publish_state()
        node.get_logger().info(
            f'spheres now {named_few(after)}: added {named_few(added) or "none"}, removed '
            f'{named_few(removed) or "none"}')
        if added:
            self.diagnostics.warn_if_unstable(
                [node.simulation.spheres.lookup(name) for name in added])

    def spawn_together(self, set_each):
        """rclpy's set_parameters service sets entry by entry; `ros2 param load` sends a
        file's keys that way. A request that changes sphere_names sets it together with the
        new spheres' keys (and the spheres.<key> arrays), in one atomic change, as a spawn
        must be; the other entries go on one by one. Results stay in the request's order."""
        node = self.node

        def set_parameters(request, response):
            entries = list(request.parameters)
            names = [e for e in entries if e.name == 'sphere_names'
                     and e.value.type == Parameter.Type.STRING_ARRAY.value]
            if not names or tuple(names[-1].value.string_array_value) == \
                    node.simulation.spheres.names:
                return set_each(request, response)
            new = set(names[-1].value.string_array_value) - set(node.simulation.spheres.names)
            together = [i for i, e in enumerate(entries) if e.name == 'sphere_names'
                        or e.name.rpartition('.')[0] in new or e.name.startswith(ARRAY_PREFIX)
                        or e.name in LOCKSTEP_KEYS]  # they name the spheres
            outcome = unknown_type_refusal([entries[i] for i in together],
                                           'nothing of the spawn')
            if outcome is None:
                outcome = node.set_parameters_atomically(
                    [Parameter.from_parameter_msg(entries[i]) for i in together])
            rest = [e for i, e in enumerate(entries) if i not in set(together)]
            each = set_each(SetParameters.Request(parameters=rest),
                            SetParameters.Response()).results if rest else []
            each = iter(each)
            response.results = [outcome if i in set(together) else next(each)
                                for i in range(len(entries))]
            return response
        return set_parameters
