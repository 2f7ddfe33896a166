"""The contact-implicit optimal control's settings and start policies (issue 43): ContactControlOptions refuses
what cannot work before anything is solved, each start policy's effect shows on a small case of its own, and a
policy added to the registry is used as the docs' recipe says."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import castrajectory as ct
from castrajectory.solve.contact import policies
from castrajectory.validation import InputError

ROOT = Path(__file__).resolve().parents[1]


def _problems(name):
    spec = importlib.util.spec_from_file_location(f"_problem_{name}", ROOT / "problems" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _push(N):
    """nosnoc's push to a target: a point mass falls onto a rough floor (μ = 0.6) and a force |u| <= 10 brings it to
    (3, 0) at rest at T = 2, minimising ∫u²."""
    return _problems("push_to_target").problem(1.5, 3.0, 0.6, 10.0, 2.0, 9.81, N)[1]


@pytest.mark.parametrize("kwargs, message", [
    ({"starts": ("warm",)}, "starts must name start policies, the last one 'cold'"),
    ({"starts": ()}, "starts must name start policies"),
    ({"penalties": (1e4, 1e3)}, "penalties must be finite, positive and increasing"),
    ({"penalties": (0.0,)}, "penalties must be finite, positive and increasing"),
    ({"timing_rounds": 0}, "timing_rounds must be a positive integer"),
    ({"iteration_budget": -1}, "iteration_budget must be a non-negative integer"),
    ({"resolve_rounds": 2.5}, "resolve_rounds must be a non-negative integer"),
    ({"certificate_tol": 0.0}, "certificate_tol must be positive and finite"),
    ({"b_tol": float("nan")}, "b_tol must be positive and finite"),
    ({"edge": 0.02}, "edge and near_edge must satisfy 0 < edge < near_edge < 0.5"),
])
def test_settings_that_cannot_work_are_refused(kwargs, message):
    with pytest.raises(InputError, match=message):
        ct.ContactControlOptions(**kwargs)


def test_an_unknown_policy_and_settings_without_contact_are_refused_before_a_solve():
    ocp = _push(20)
    with pytest.raises(InputError, match=r"unknown start policies \['sideways'\]: the policies are "):
        ocp.solve(contact=ct.ContactControlOptions(starts=("sideways", "cold")))
    x, mass, terms, u = _block()
    block = ct.OptimalControl(ct.LagrangianSystem(x, mass, terms), T=1.0, N=10)
    block.initial(q=[0.0], qd=[0.0])
    block.final(q=[1.0], qd=[0.0])
    block.minimize(running=u ** 2)
    with pytest.raises(InputError, match="this system has no contact"):
        block.solve(contact=ct.ContactControlOptions())


def _block():
    import casadi as ca
    u = ct.Control("u", 1, lower=-50, upper=50)
    x = ca.SX.sym("x", 1)
    return x, ct.MassMatrix(1.0), [ct.Force(u)], u


def test_the_warm_start_keeps_the_rounds_on_the_cheaper_optimum():
    """The hopper at N = 20 (nosnoc's 20 stages): its later timing rounds started warm (from the last round's
    primal-dual point) certify 11.0379; started cold every round (the homotopy's barrier from the last answer), the
    rounds leave that optimum and end with an event pinned at a costlier point (measured 13.79, Event_Pinned, 5014
    iterations against 941).  Both motions are certified: the policy changes which optimum, not the physics."""
    hop = _problems("hopper")
    ocp = hop.problem(N=20)
    warm = ocp.solve(guess=ocp.guess)
    ocp = hop.problem(N=20)
    cold = ocp.solve(guess=ocp.guess, contact=ct.ContactControlOptions(starts=("cold",)))
    assert warm.success and warm.certificate <= 1e-7
    assert warm.cost == pytest.approx(11.0378620, abs=1e-6)
    assert cold.certificate <= 1e-7
    assert (not cold.success) or cold.cost > warm.cost * (1 + 1e-3)
    assert cold.cost > 1.2 * warm.cost          # (measured 13.79 / 11.04 = 1.25)


def test_the_near_start_reaches_the_finer_grids_optimum_more_tightly():
    """The ladder of grids: the push at N = 40 starts from its answer at N = 20.  Its first round started near (a
    small barrier, nothing pushed off its bounds: the coarse answer's march kept) stops at 67.90734876; started
    cold (the homotopy's barrier at 0.1, bounds pushed by 1e-2) it stops 1.1e-6 higher, at the barrier's own
    perturbation of the optimum.  Both certified, both with one impact at the free fall's landing time.  (Compared
    before the moves of the certified answer, ``across_rounds = 0``: by default both answers' slip, stopped on a node,
    is moved into the step after it, and both land on 67.9068343, 5.1e-4 lower)"""
    near = _push(40).solve(contact=ct.ContactControlOptions(across_rounds=0))
    cold = _push(40).solve(contact=ct.ContactControlOptions(starts=("warm", "from_last", "cold"), across_rounds=0))
    assert near.success and cold.success and near.grids == cold.grids == [20, 40]
    assert max(near.certificate, cold.certificate) <= 1e-7
    landing = np.sqrt(2 * 1.5 / 9.81)
    for sol in (near, cold):
        assert len(sol.impact_times[0]) == 1 and abs(sol.impact_times[0][0] - landing) < 2.0 / 40
    assert cold.cost - near.cost > 1e-7          # (measured 1.12e-6)
    assert near.cost == pytest.approx(67.9073487647, abs=1e-8)


def test_a_policy_added_to_the_registry_starts_the_rounds(monkeypatch):
    """The recipe of docs/optimal-control.md: a start policy is a function of (problem, round) returning a solve or
    None, registered by name in policies.STARTS and listed in ContactControlOptions.starts.  Here a policy that
    starts the first round from the guess with the warm barrier: the push at N = 20 then certifies at the same
    optimum as the default start (to 1e-7 of the cost)."""
    used = []

    def gentle(P, R):
        if R.res is not None:
            return None
        used.append(R.branch.timed.shape)
        return P.ladder(R.init, {"mu_init": 1e-2}, R.bounds)

    monkeypatch.setitem(policies.STARTS, "gentle", gentle)
    mine = _push(20).solve(contact=ct.ContactControlOptions(starts=("gentle", "warm", "cold")))
    default = _push(20).solve()
    assert used == [(20, 1)]
    assert mine.success and mine.certificate <= 1e-7
    assert mine.cost == pytest.approx(default.cost, rel=1e-7)


@pytest.mark.parametrize("make, message", [
    (lambda c: c.MarchOptions(chunk_steps=0), "chunk_steps must be a positive integer"),
    (lambda c: c.MarchOptions(newton_iter=2.0), "newton_iter must be a positive integer"),
    (lambda c: c.MarchOptions(step_tol=-1e-12), "step_tol must be positive and finite"),
    (lambda c: c.MarchOptions(runaway=float("inf")), "runaway must be positive and finite"),
    (lambda c: c.ContactOptions(impulse_tol=0.0), "impulse_tol must be positive and finite"),
    (lambda c: c.ContactOptions(guess_chunk=0), "guess_chunk must be a positive integer"),
])
def test_march_and_report_settings_that_cannot_work_are_refused(make, message):
    from castrajectory.solve import contact
    with pytest.raises(InputError, match=message):
        make(contact)


@pytest.mark.parametrize("scene", ["ball", "drop"])
def test_the_march_chunk_length_does_not_change_the_answer(scene):
    """MarchOptions.chunk_steps only groups the steps that keep their modes into one call: chunks of 8 and of 64 give
    the same certified trajectory (measured: identical to the last bit, the certificate's Newton step of the whole
    system polishing both), the same impacts at the same times."""
    from castrajectory.models import collision as col
    from castrajectory.solve import contact, trajectory
    g = 9.81
    system, q0, v0, T, N = ((col.bouncing_ball(1.0, g, 0.7), [1.0], [0.0], 3.0, 1500) if scene == "ball" else
                            (col.rectangle_drop(1.0, 2.0, 1.0, g, 0.5), [0.0, 2.0, 0.3], [0.5, 0.0, 1.0], 1.5, 600))
    runs = [trajectory.solve_initial_value(system, q0, v0, T, N, contact=contact.ContactOptions(
        march_options=contact.MarchOptions(chunk_steps=cs))) for cs in (8, 64)]
    assert all(r.success for r in runs)
    assert float(np.max(np.abs(runs[0].q - runs[1].q))) <= 1e-12
    assert [i.contact for i in runs[0].impacts] == [i.contact for i in runs[1].impacts]
    assert max(abs(a.t - b.t) for a, b in zip(runs[0].impacts, runs[1].impacts)) <= 1e-12


def test_the_iteration_budget_is_the_solves_own_or_the_runs():
    """ContactControlOptions.iteration_budget caps every Ipopt iteration of one contact-implicit solve (its rounds,
    branches and coarser grids) and says so when it ends the solve; a run's budget (--max-iter, budget.iterations)
    takes its place where one is open.  The hopper at N = 20 needs 941 iterations."""
    from castrajectory.solve import budget
    hop = _problems("hopper")
    ocp = hop.problem(N=20)
    own = ocp.solve(guess=ocp.guess, contact=ct.ContactControlOptions(iteration_budget=300))
    assert not own.success and own.iterations <= 300
    assert own.message.endswith("(the solve's budget of 300 Ipopt iterations is spent)")
    ocp = hop.problem(N=20)
    with budget.iterations(250):
        run = ocp.solve(guess=ocp.guess, contact=ct.ContactControlOptions(iteration_budget=10_000))
        assert budget.remaining() == 0
    assert not run.success and run.iterations <= 250
    ocp = hop.problem(N=20)
    full = ocp.solve(guess=ocp.guess)                  # (nothing of the earlier budgets is left behind)
    assert full.success and full.cost == pytest.approx(11.0378620, abs=1e-6)
