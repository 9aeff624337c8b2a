"""The README's controller (examples/lift_the_cork.py), run as the README says, in lockstep."""
import importlib.util
from pathlib import Path

EXAMPLE = Path(__file__).resolve().parents[1] / 'examples' / 'lift_the_cork.py'


def load_example():
    spec = importlib.util.spec_from_file_location('lift_the_cork', EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_readme_controller_holds_the_cork_a_metre_above_the_water(pool_sim):
    example = load_example()
    sim = pool_sim({'lockstep_inputs': ['cork'], 'wrench_timeout': 0.0})
    sim.add(example.LiftTheCork)
    sim.advance(15.0)
    position, velocity = sim.state('cork')
    assert abs(position[2] - example.TARGET_Z_M) < 0.02 and abs(velocity[2]) < 0.01


def test_the_example_is_about_twenty_lines_of_code():
    code = [line for line in EXAMPLE.read_text().splitlines()
            if line.strip() and not line.lstrip().startswith(('#', '"""', 'python '))]
    assert len(code) <= 25
