"""A chain of uniform rods hung from a pin, built from bodies and joints (ct.Multibody): each rod its own centre of
mass and angle (maximal coordinates), each pin two constraints, so that its rows grow linearly with the links.

    castrajectory system examples/rod_chain.py --scheme galerkin4
    castrajectory system examples/rod_chain.py --scheme galerkin4 --animate chain.gif
"""
import castrajectory as ct

links_n, m, length = 4, 1.0, 1.0
title = "a chain of four rods"
T, n = 3.0, 120

chain = ct.Multibody(g=9.81)
parent, at = chain.world, (0.0, 0.0)
for i in range(links_n):
    rod = chain.body(f"rod{i + 1}", mass=m, inertia=m * length ** 2 / 12,
                     outline=[(0.0, length / 2), (0.0, -length / 2)])
    chain.revolute(parent, rod, parent_point=at, child_point=(0.0, length / 2), name=f"pin{i + 1}")
    parent, at = rod, (0.0, -length / 2)

q0, qd0 = chain.state({"pin1": 0.5})      # the first pin at 0.5 rad, the rest straight, at rest
links = chain.links                       # pictures: each rod drawn end to end


def system():
    return chain.system()
