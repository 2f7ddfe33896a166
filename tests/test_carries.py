"""A scene carries only the terms it needs, read from its built NLP (the `program` of its answer)."""
import pytest

from castrajectory.models import collision, pendulum
from castrajectory.solve import droplet, simulate, trajectory


def test_double_pendulum_has_no_complementarity_and_no_gravity_at_g0():
    r = simulate.simulate(pendulum.double_pendulum(g=9.81), [1.0, 0.5], [0.0, 0.0], 1.0, 100)
    prog = r.as_dict()["program"]
    assert prog["complementarity_pairs"] == 0 and prog["inequality_rows"] == 0
    assert prog["terms"] == ["kinetic: 2 atoms", "gravity"]
    # midpoint: 2 DEL rows per step, 2 unknowns per node (q_0 fixed by bounds, counted as variables)
    assert prog["equality_rows"] == 2 * 100 and prog["variables"] == 2 * 101
    r0 = simulate.simulate(pendulum.double_pendulum(g=0.0), [1.0, 0.5], [1.0, 0.0], 1.0, 100)
    assert "gravity" not in r0.as_dict()["program"]["terms"]
    assert r0.as_dict()["program"]["families"][1]["instructions"] < prog["families"][1]["instructions"]


@pytest.mark.parametrize("g", [9.81, 0.0])
def test_contact_pairs_are_three_per_step_and_contact(g):
    tr = trajectory.solve_initial_value(collision.bouncing_ball(1.0, g, 1.0), [1.0], [-1.0], 1.0, 100)
    prog = tr.program
    steps = prog["steps"]
    assert prog["complementarity_pairs"] == 3 * steps + 1     # node, sub-node, impact law; the end node
    assert ("gravity" in prog["terms"]) == (g != 0.0)
    assert "contact: 1 gap, e = 1" in prog["terms"]


def test_a_baseline_has_no_program_and_the_droplet_lists_its_terms():
    r = simulate.simulate(pendulum.double_pendulum(), [1.0, 0.5], [0.0, 0.0], 1.0, 100, method="rk4")
    assert r.as_dict()["program"] is None
    pinned = droplet.solve(droplet.Droplet(span=1.5), 100)
    assert pinned.program["terms"] == ["surface tension γ_gl × length", "area constraint", "span pinned"]
    free = droplet.solve(droplet.Droplet(), 100)
    assert "wetting (γ_sl − γ_sg) × span" in free.program["terms"]
    assert free.program["complementarity_pairs"] == 0
