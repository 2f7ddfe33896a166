"""A two-link arm loaded from an MJCF file (examples/models/arm.xml) by MuJoCo's own compiler (ct.load_mjcf): its
bodies, inertias, joints, the shoulder's damping and range, and its capsules for the pictures.

    castrajectory system examples/arm.py --scheme galerkin4
    castrajectory system examples/arm.py --scheme galerkin4 --animate arm.gif
"""
import os

import castrajectory as ct

title = "an arm from an MJCF file"
T, n = 2.0, 80

arm = ct.load_mjcf(os.path.join(os.path.dirname(os.path.abspath(__file__)), "models", "arm.xml"))
q0, qd0 = arm.state({"shoulder": 1.0, "elbow": 0.5})   # MuJoCo's qpos, by joint name; at rest
links = arm.links                                      # pictures: the capsules' ends and the joints


def system():
    return arm.system()                                # maximal coordinates; arm.system("joint") for qpos
