"""The block triangular solve of a square sparse system (solve/triangular.py) and Newton's method on an initial-value
trajectory (NLP.newton), against dense linear algebra and Ipopt's answer on the same rows."""
from __future__ import annotations

import casadi as ca
import numpy as np

import castrajectory as ct
from castrajectory.solve.triangular import BlockTriangular


def _dm(A):
    rows, cols = np.nonzero(A)
    order = np.lexsort((rows, cols))
    sp = ca.Sparsity.triplet(A.shape[0], A.shape[1], rows[order].tolist(), cols[order].tolist())
    return sp, A[rows[order], cols[order]]


def test_a_block_triangular_system_is_solved_block_by_block():
    """A random block lower-triangular matrix (8 dense blocks of 5, two sparse sub-diagonal coupling blocks), its
    rows and columns shuffled: the Dulmage–Mendelsohn form finds 8 blocks, and the solve
    agrees with numpy's dense one to rounding."""
    rng = np.random.default_rng(3)
    nb, b = 8, 5
    A = np.zeros((nb * b, nb * b))
    for k in range(nb):
        blk = np.eye(b) * 4 + rng.normal(size=(b, b))          # (dense: one strongly connected block)
        A[k * b:(k + 1) * b, k * b:(k + 1) * b] = blk
        for j in (k - 1, k - 2):
            if j >= 0:
                A[k * b:(k + 1) * b, j * b:(j + 1) * b] = (rng.random((b, b)) < 0.3) * rng.normal(size=(b, b))
    P, Q = rng.permutation(nb * b), rng.permutation(nb * b)
    A = A[P][:, Q]
    sp, nz = _dm(A)
    bt = BlockTriangular(sp)
    assert bt.applies and bt.blocks == nb and bt.largest == b
    r = rng.normal(size=nb * b)
    x = bt.solve(nz, r)
    assert np.max(np.abs(x - np.linalg.solve(A, r))) < 1e-12 * np.max(np.abs(x))


def test_an_irreducible_system_has_no_block_form():
    """A matrix whose graph is strongly connected (a cycle through every unknown) is one block: nothing to use."""
    n = 6
    A = np.eye(n) * 3 + np.roll(np.eye(n), 1, axis=1)
    sp, _ = _dm(A)
    bt = BlockTriangular(sp)
    assert bt.blocks == 1 and not bt.applies


def test_newton_block_by_block_is_ipopts_answer():
    """A chain of 8 rods in maximal coordinates (ct.Multibody: 24 coordinates, 16 pin rows; galerkin4, N = 30, its
    steps' blocks of 80 unknowns): the level solved by Newton's method block by block (NLP.newton, 2 iterations) and
    by Ipopt from the same guess (2 iterations) agree to rounding (measured 2.2e-16), and the answer is the march of
    the same scheme (6.0e-14)."""
    from castrajectory.discretise.lagrangians import discrete_mechanics
    from castrajectory.solve import trajectory as tj
    from castrajectory.solve.nlp import NEWTON_MIN_BLOCK
    mb = ct.Multibody(g=9.81)
    parent, at = mb.world, (0.0, 0.0)
    for i in range(8):
        rod = mb.body(f"rod{i}", 1.0, 1.0 / 12)
        mb.revolute(parent, rod, parent_point=at, child_point=(0.0, 0.5))
        parent, at = rod, (0.0, -0.5)
    system = mb.system()
    q0, v0 = mb.state(np.r_[0.5, np.zeros(7)])
    dm = discrete_mechanics(system, "galerkin4")
    p0 = np.asarray(system.momentum(q0, v0, 0.0)).reshape(-1)
    tn = tj.TrajectoryNLP(dm, 30, 1.0, "initial_value", q0, p0)
    guess = {k: v for k, v in tj._integrated(dm, q0, v0, tn.h, tn.N)[0].items() if k in tn.nlp.variable_names}
    res = tn.nlp.newton(guess, 1e-12, bounds=tn.fixed_bounds())
    plans = [p for p in tn.nlp._block_plans.values() if p is not None]
    assert [(p[0].blocks, p[0].largest) for p in plans] == [(30, 80)] and 80 >= NEWTON_MIN_BLOCK
    assert res is not None and res.success and 1 <= res.iterations <= 4
    ipopt = tn.nlp.solve(init=guess, options=dict(tj.TRAJECTORY_IPOPT), bounds=tn.fixed_bounds())
    assert ipopt.success
    assert np.max(np.abs(res.values["q"] - ipopt.values["q"])) < 1e-13
    run = ct.simulate(system, q0, v0, 1.0, 30, scheme="galerkin4", method="march")
    assert np.max(np.abs(res.values["q"].reshape(-1, system.nq) - run.q)) < 5e-12
