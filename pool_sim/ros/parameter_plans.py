"""What a parameter request would change, checked once: the plan a transaction applies.

A plan is made without changing anything: it holds the core's checked live changes
(Simulation.check_change: one check per value), the new scene of a spawn or remove, and the
new lockstep settings. Applying it (parameter_changes.py) checks nothing again.
"""
from typing import NamedTuple, Optional

import numpy as np

from pool_sim.physics import InvalidInput
from pool_sim.physics.scene import Scene
from pool_sim.physics.schema import check_some_sphere_names, SPHERE_KEYS
from pool_sim.physics.spheres import named_few
from pool_sim.ros.parameters import (ARRAY_PREFIX, array_parameter, is_ros_own,
                                     LIVE_SPHERE_KEYS, LOCKSTEP_KEYS, plain)


class Plan(NamedTuple):
    """A request's changes, each checked: apply them as they are."""
    spheres: Optional[Scene]  # the scene after a spawn or remove; None: the same spheres
    live: list  # [(sphere name, CheckedChange)] of spheres kept (indices after the spawn)
    settings: Optional[Scene]  # the scene with the request's lockstep settings, or None


def plan_request(node, parameters, following_lift_areas=()) -> Plan:
    """The Plan of a parameter request to `node` (its simulation, scene and per-sphere
    form), or InvalidInput. following_lift_areas: names the request carries only to show a
    lift area following its radius (the core moves it with the radius)."""
    simulation, per_sphere = node.simulation, node.per_sphere
    for parameter in parameters:
        if is_ros_own(parameter.name) and not node.has_parameter(parameter.name):
            # rclpy's own names are rclpy's to take, once declared (a qos_overrides key is
            # read_only); undeclared, they are names like any unknown one.
            raise InvalidInput(unknown_key_reason(parameter.name, per_sphere,
                                                  simulation.spheres.names))
    values = {p.name: plain(p.value) for p in parameters
              if not is_ros_own(p.name) and p.name not in following_lift_areas}
    settings = {name: values.pop(name) for name in LOCKSTEP_KEYS if name in values}
    if ('sphere_names' in values
            and tuple(values['sphere_names'] or ()) != simulation.spheres.names):
        return _plan_spheres(node, values, settings)
    # Checked as a scene checks them (against sphere_names too).
    return Plan(None, _live_changes(node, values),
                node.scene.with_values(**settings) if settings else None)


def _live_changes(node, values):
    """[(sphere, CheckedChange)] of a request's live keys; InvalidInput for anything that
    cannot change while running."""
    spheres = node.simulation.spheres
    changes = []
    for name, value in values.items():
        if name == 'sphere_names':
            continue
        if not node.per_sphere and name.startswith(ARRAY_PREFIX):
            changes += _live_array_changes(node, name, value, values)
            continue
        sphere, _, key = name.rpartition('.')
        if sphere not in spheres.index or key not in SPHERE_KEYS or not node.per_sphere:
            raise InvalidInput(unknown_key_reason(name, node.per_sphere, spheres.names))
        changes.append(live_change(node.simulation, name, value))
    return changes


def live_change(simulation, name, value):
    """(sphere, CheckedChange) of a kept sphere's '<sphere>.<key>', or InvalidInput if the
    key cannot change while running or the value is refused."""
    sphere, _, key = name.rpartition('.')
    if key not in LIVE_SPHERE_KEYS:
        raise InvalidInput(f'{name}: cannot change while running')
    return sphere, simulation.check_change(sphere, key, value)


def _live_array_changes(node, name, value, values):
    found = array_parameter(name)
    spheres = node.simulation.spheres
    if found is None:
        raise InvalidInput(unknown_key_reason(name, False, node.scene.sphere_names))
    key, component = found
    rows = as_rows(name, value, spheres.count)
    if key not in LIVE_SPHERE_KEYS:
        initial = node.scene.sphere_array(key)
        if not np.array_equal(rows, initial if component is None else initial[:, component]):
            raise InvalidInput(f'{name}: cannot change while running (only '
                               f'{", ".join(ARRAY_PREFIX + k for k in LIVE_SPHERE_KEYS)} '
                               'can, and sphere_names, to add and remove spheres)')
        return []
    current = getattr(spheres, key)
    if key == 'lift_area':
        # Given where it differs from what it would be after this request: a following
        # area moves with a radius in the same request (an edited dump loaded at once).
        radius = values.get(f'{ARRAY_PREFIX}radius')
        radius = (spheres.radius if radius is None
                  else as_rows(f'{ARRAY_PREFIX}radius', radius, spheres.count))
        # pi r r, as the core computes a following area: a dump loaded back is no change.
        current = np.where(spheres.lift_area_follows_radius, np.pi * radius * radius, current)
    changed = np.flatnonzero(~(rows == current))  # NaN counts as changed
    return [(spheres.names[i], node.simulation.check_change(spheres.names[i], key,
                                                            float(rows[i])))
            for i in changed]


def _plan_spheres(node, values, settings):
    """Spawn and remove: the new scene (with the lockstep `settings` of the request), and
    the live changes of the spheres kept. The new scene keeps the kept spheres' initial
    values (reset goes back to them); keys of a kept sphere in the request are live
    changes, as in any other request. The live changes are checked against the spheres
    now and carry the indices they will have after the change."""
    names = check_some_sphere_names(values['sphere_names'], node.scene.reserved_names)
    index = node.simulation.spheres.index
    given, live = {}, {}
    if node.per_sphere:
        for name, value in values.items():
            sphere = name.rpartition('.')[0]
            if name == 'sphere_names':
                continue
            if sphere not in names:
                raise InvalidInput(unknown_key_reason(name, True, names))
            (live if sphere in index else given)[name] = value
    else:
        given, live = _kept_and_given_arrays(node, names, values)
    scene = node.scene.with_spheres(names, {**given, **settings})
    after = {name: i for i, name in enumerate(names)}
    changes = []
    for name, value in live.items():
        sphere, change = live_change(node.simulation, name, value)
        changes.append((sphere, change._replace(index=after[sphere])))
    return Plan(scene, changes, None)


def _kept_and_given_arrays(node, names, values):
    """Vectorised over the kept spheres (a spawn at 100 000 spheres is one request): the
    arrays the new scene is given (the kept spheres' initial values), and the live keys of
    kept spheres that the request changes, {'<sphere>.<key>': value}."""
    index = node.simulation.spheres.index
    kept = [(i, index[name]) for i, name in enumerate(names) if name in index]
    new_at = np.array([i for i, _ in kept], dtype=int)
    old_at = np.array([j for _, j in kept], dtype=int)
    given, live = {}, {}
    for name, value in values.items():
        if name == 'sphere_names':
            continue
        found = array_parameter(name)
        if found is None:
            raise InvalidInput(unknown_key_reason(name, False, names))
        key, component = found
        rows = as_rows(name, value, len(names))
        initial = node.scene.sphere_array(key)[old_at]
        initial = initial if component is None else initial[:, component]
        if key in LIVE_SPHERE_KEYS:
            current = getattr(node.simulation.spheres, key)[old_at]
            for j in np.flatnonzero(~(rows[new_at] == current)):  # NaN: changed
                live[f'{names[new_at[j]]}.{key}'] = float(rows[new_at[j]])
        else:
            differs = ~(rows[new_at] == initial)
            if differs.any():
                first = int(new_at[np.flatnonzero(differs)[0]])
                raise InvalidInput(f'{name}: {names[first]} (index {first}) is kept and '
                                   'cannot change it while running')
        rows[new_at] = initial
        given[name] = rows.tolist()
    return given, live


def as_rows(name, value, count) -> np.ndarray:
    """A spheres.<key> array parameter as (count,) floats, or InvalidInput."""
    try:
        rows = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(f'{name}: expected {count} numbers, got {value!r:.60}') from None
    if rows.ndim != 1 or rows.size != count:
        raise InvalidInput(f'{name}: expected {count} values (one per sphere in '
                           f'sphere_names), got {rows.size}')
    return rows


def unknown_key_reason(name, per_sphere, sphere_names) -> str:
    form = ('<sphere>.mass, <sphere>.radius and <sphere>.lift_area' if per_sphere else
            ', '.join(ARRAY_PREFIX + key for key in LIVE_SPHERE_KEYS))
    return (f'{name}: not a parameter of this node (spheres: {named_few(sphere_names)}); '
            f'while running {form} can change, and sphere_names (with the new spheres\' '
            'keys in the same request) adds and removes spheres')
