"""Three equal bodies chasing each other along a figure eight (Chenciner and Montgomery's orbit).

Three unit masses attract by Newton's law with G = 1: U = −Σ_{i<j} 1/|x_i − x_j|.  Started from
x₁ = −x₂ = (0.97000436, −0.24308753), x₃ = 0, v₃ = (−0.93240737, −0.86473146), v₁ = v₂ = −v₃/2, they
move along one figure-eight curve, a third of a period apart, with the period T₀ = 6.32591398 (Moore's
numbers as refined by Chenciner and Montgomery, 2000).  The total momentum is zero and stays zero; the
angular momentum is zero; the energy is E = −1.287144…

The oracle: the orbit closes after every period (to the 8 digits the initial conditions carry), and the
Newtonian equations ẍ_i = −Σ_j (x_i − x_j)/|x_i − x_j|³ integrated by scipy's DOP853 at rtol = atol =
1e-13 (scripts/estimate_battery.py: over 10 periods that reference agrees with DOP853 at 1e-12 to the
figure it prints, which bounds its own error).  The orbit is linearly stable, so errors grow about
linearly with time.

    castrajectory system examples/three_body_figure8.py --scheme galerkin8 --n 400
"""
import casadi as ca
import castrajectory as ct

G = 1.0
masses = (1.0, 1.0, 1.0)
period = 6.32591398
title = "three-body figure eight"
T, n = period, 200          # one period (10 periods: scripts/estimate_battery.py)
_x1, _v3 = (0.97000436, -0.24308753), (-0.93240737, -0.86473146)
q0 = [_x1[0], _x1[1], -_x1[0], -_x1[1], 0.0, 0.0]                           # x1, y1, x2, y2, x3, y3
qd0 = [-_v3[0] / 2, -_v3[1] / 2, -_v3[0] / 2, -_v3[1] / 2, _v3[0], _v3[1]]
links = False               # pictures: three bodies, no chain


def system():
    q = ca.SX.sym("q", 6)
    bodies = [q[0:2], q[2:4], q[4:6]]
    U = 0
    for i in range(3):
        for j in range(i + 1, 3):
            U = U - G * masses[i] * masses[j] / ca.norm_2(bodies[i] - bodies[j])
    return ct.LagrangianSystem(q, ct.Atoms(bodies, list(masses)), [ct.Potential(U, "gravity")],
                               names=["x1", "y1", "x2", "y2", "x3", "y3"])
