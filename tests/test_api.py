"""The public API: `import castrajectory as ct` exposes what a user composes, and every public name's
docstring example runs and prints what it says."""
import doctest

import pytest

import castrajectory as ct


def test_the_public_names():
    assert set(ct.__all__) == {"LagrangianSystem", "Atoms", "MassMatrix", "Gravity", "Spring", "Potential",
                               "Contact", "RigidBody", "Inertia", "simulate", "Force", "Dissipation", "Damping",
                               "time", "velocity", "schemes", "rotation", "body_point", "unit_norm",
                               "quaternion_rate", "angular_velocity", "angular_momentum", "Control",
                               "OptimalControl", "ContactControlOptions", "Multibody", "load_mjcf", "load_urdf"}


@pytest.mark.parametrize("name", sorted(ct.__all__))
def test_docstring_example_runs(name):
    obj = getattr(ct, name)
    assert obj.__doc__ and ">>>" in obj.__doc__, f"{name} has no runnable example"
    tests = doctest.DocTestFinder(recurse=False).find(obj, name, globs={})
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for t in tests:
        runner.run(t)
    assert runner.failures == 0 and runner.tries > 0


def test_inertia_about_a_pivot_example_runs():
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for t in doctest.DocTestFinder(recurse=False).find(ct.Inertia.about, "Inertia.about", globs={}):
        runner.run(t)
    assert runner.failures == 0 and runner.tries > 0
