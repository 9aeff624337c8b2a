"""A value sent to the node reaches the core by one path and is checked once, whichever way
it came: ~/set_mass, ~/set_radius, rclpy's set_parameters (`ros2 param set`),
set_parameters_atomically, or a spawn. The checks are counted where the core makes them:
spheres.check_number (one value) and, for a scene's arrays, schema._rows_allowed (many at
once); rclpy's own descriptor check is rclpy's, not counted. Each value sent is one no
other sphere has, so its checks are told apart from the others'."""
from collections import Counter

import numpy as np
import pytest
from rcl_interfaces.msg import Parameter as ParameterMessage, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters, SetParametersAtomically

from pool_sim.physics import schema as schema_module, spheres as spheres_module

SENT = (7.25, 0.0725, 3.125)  # kg, m, kg: no sphere of the default pool has them


@pytest.fixture
def checks(monkeypatch):
    """Counter: how many times each value of SENT went through a check of the core."""
    counted = Counter()
    number, rows_allowed = spheres_module.check_number, schema_module._rows_allowed

    def counting_number(name, value, *args, **kwargs):
        if isinstance(value, float) and value in SENT:
            counted[value] += 1
        return number(name, value, *args, **kwargs)

    def counting_rows(spec, rows):
        for value in SENT:
            counted[value] += int(np.count_nonzero(np.asarray(rows) == value))
        return rows_allowed(spec, rows)

    monkeypatch.setattr(spheres_module, 'check_number', counting_number)
    monkeypatch.setattr(schema_module, 'check_number', counting_number)
    monkeypatch.setattr(schema_module, '_rows_allowed', counting_rows)
    return counted


def double(name, value):
    return ParameterMessage(name=name, value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE,
                                                           double_value=value))


def names(name, values):
    return ParameterMessage(name=name, value=ParameterValue(
        type=ParameterType.PARAMETER_STRING_ARRAY, string_array_value=list(values)))


def doubles(name, values):
    return ParameterMessage(name=name, value=ParameterValue(
        type=ParameterType.PARAMETER_DOUBLE_ARRAY, double_array_value=list(values)))


def accepted(response):
    results = response.results if hasattr(response, 'results') else [response.result]
    assert all(result.successful for result in results), results
    return True


@pytest.mark.parametrize('service, key, value', [('set_mass', 'mass', 7.25),
                                                 ('set_radius', 'radius', 0.0725)])
@pytest.mark.parametrize('per_sphere', [True, False])
def test_a_world_service_checks_a_value_once(pool_sim, checks, service, key, value,
                                             per_sphere):
    sim = pool_sim({'per_sphere_topics': per_sphere})
    checks.clear()
    assert accepted(sim.call(SetParameters, service,
                             SetParameters.Request(parameters=[double('cork', value)])))
    assert checks[value] == 1
    with sim.node.lock():
        spheres = sim.node.simulation.spheres
        assert getattr(spheres, key)[spheres.lookup('cork')] == value
    shown = (sim.node.get_parameter(f'cork.{key}').value if per_sphere
             else sim.node.get_parameter(f'spheres.{key}').value[spheres.lookup('cork')])
    assert shown == value  # the table shows what the core has


def test_ros2_param_set_checks_a_value_once(pool_sim, checks):
    sim = pool_sim()
    checks.clear()
    assert accepted(sim.call(SetParameters, 'set_parameters',
                             SetParameters.Request(parameters=[double('cork.mass', 7.25)])))
    assert checks[7.25] == 1
    assert sim.state('cork') is not None and sim.node.get_parameter('cork.mass').value == 7.25


def test_an_atomic_request_checks_each_value_once(pool_sim, checks):
    sim = pool_sim()
    checks.clear()
    request = SetParametersAtomically.Request(parameters=[
        double('cork.mass', 7.25), double('steel.radius', 0.0725)])
    assert accepted(sim.call(SetParametersAtomically, 'set_parameters_atomically', request))
    assert checks[7.25] == 1 and checks[0.0725] == 1


@pytest.mark.parametrize('per_sphere', [True, False])
def test_a_spawn_checks_the_new_sphere_and_a_kept_spheres_change_once(pool_sim, checks,
                                                                     per_sphere):
    sim = pool_sim({'per_sphere_topics': per_sphere})
    with sim.node.lock():
        before = list(sim.node.simulation.spheres.names)
        masses = sim.node.simulation.spheres.mass.tolist()
    after = before + ['buoy']
    if per_sphere:
        entries = [names('sphere_names', after), double('buoy.mass', 3.125),
                   double('cork.mass', 7.25)]
    else:
        masses = [7.25 if name == 'cork' else mass for name, mass in zip(before, masses)]
        entries = [names('sphere_names', after), doubles('spheres.mass', masses + [3.125])]
    checks.clear()
    assert accepted(sim.call(SetParametersAtomically, 'set_parameters_atomically',
                             SetParametersAtomically.Request(parameters=entries)))
    assert checks[3.125] == 1 and checks[7.25] == 1
    with sim.node.lock():
        spheres = sim.node.simulation.spheres
        assert spheres.mass[spheres.lookup('buoy')] == 3.125
        assert spheres.mass[spheres.lookup('cork')] == 7.25
