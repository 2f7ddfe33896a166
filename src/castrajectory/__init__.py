"""castrajectory: variational mechanics posed as nonlinear programs in CasADi and solved with Ipopt.

The package is built in layers; each folder is one room, and imports only point down
(``tests/test_layers.py`` checks it):

* ``models/``      describe: what the physics is (Lagrangian systems, the droplet, the impact law),
                   each model with its analytic oracle;
* ``discretise/``  how it becomes finitely many unknowns: the named program, discrete Lagrangians,
                   the whole-trajectory, droplet and contact transcriptions;
* ``baselines/``   time-steppers kept for comparison only;
* ``solve/``       one NLP handed to Ipopt, the solve strategies and the one entry point ``simulate``;
* ``inspect/``     studies, error measures and pictures (the only place matplotlib is imported);
* ``cli/``         argument parsing, the scene registry, the console command and the report.

``result`` (the one result contract) and ``validation`` (the bad-input error) sit under all of them.

The public API is what a user composes into a system of their own (each name's docstring holds a
runnable example, run by ``tests/test_api.py``)::

    import castrajectory as ct
    system = ct.LagrangianSystem(q, ct.Atoms(positions, masses), [ct.Gravity(9.81), ct.Spring(...)],
                                 constraints=[...], contact=ct.Contact(gaps, restitution=0.9))
    run = ct.simulate(system, q0, qd0, T, N, scheme="galerkin4", rtol=1e-6)

``LagrangianSystem``, ``Atoms``, ``MassMatrix``, ``Gravity``, ``Spring``, ``Potential``, ``Contact``,
``RigidBody`` and ``Inertia`` describe, with the non-conservative ``Force``, ``Dissipation`` and ``Damping``
terms, the time symbol ``time()`` and the velocity symbol ``velocity(q)``; for 3-D bodies on a
quaternion, ``rotation``, ``body_point``, ``unit_norm``, ``quaternion_rate``, ``Inertia.about`` (a pivot),
and ``angular_velocity`` / ``angular_momentum`` of a solution (its ``q``, ``v``, ``p``); ``schemes()`` lists the
discrete Lagrangians with their orders; ``simulate`` solves (one whole-trajectory stationary-action
problem) and returns the result contract with ``t``, ``q``, ``energy``, ``error_estimate`` and
``warnings``; ``OptimalControl`` poses a problem of optimal control on the discrete action, and
``ContactControlOptions`` holds the settings of its solve through contact; ``Multibody`` builds a system from bodies
and joints, and ``load_mjcf`` / ``load_urdf`` one from a model file.  Everything else is internal.

The flat module names of earlier versions (``castrajectory.droplet``, ``castrajectory.nlp``, ...)
still import: they are aliases of the modules that now hold their contents (see ``_MOVED``).  Policy: they are
deprecated (importing one warns with ``DeprecationWarning`` and names the new home), kept through the 0.x
releases, and removed at 1.0.
"""
from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import types
import warnings

#: Old flat module name -> the module that holds its contents now.
_MOVED = {
    "mechanics": "castrajectory.models.mechanics",
    "pendulum": "castrajectory.models.pendulum",
    "collision": "castrajectory.models.collision",
    "droplet": "castrajectory.solve.droplet",
    "discrete": "castrajectory.discretise.lagrangians",
    "nlp": "castrajectory.solve.nlp",
    "assembly": "castrajectory.solve.assembly",
    "jit": "castrajectory.solve.jit",
    "trajectory": "castrajectory.solve.trajectory",
    "contact": "castrajectory.solve.contact",
    "simulate": "castrajectory.solve.simulate",
    "stepping": "castrajectory.baselines.stepping",
    "study": "castrajectory.inspect.study",
    "plotting": "castrajectory.inspect.plotting",
    "report": "castrajectory.cli.report",
}


class _Alias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """``import castrajectory.<old>`` gives the very module object of its new home (no copy)."""

    def find_spec(self, fullname, path=None, target=None):
        head, _, leaf = fullname.partition(".")
        if head == __name__ and leaf in _MOVED:
            return importlib.util.spec_from_loader(fullname, self)
        return None

    def create_module(self, spec):
        new = _MOVED[spec.name.partition(".")[2]]
        warnings.warn(f"{spec.name} is deprecated and goes at castrajectory 1.0: import {new}", DeprecationWarning,
                      stacklevel=2)
        module = importlib.import_module(new)
        self._spec = module.__spec__
        return module

    def exec_module(self, module):
        module.__spec__ = self._spec  # the import system stamped the alias's spec on it; restore


if not any(isinstance(f, _Alias) for f in sys.meta_path):
    sys.meta_path.append(_Alias())

from .models.mechanics import (  # noqa: E402
    Atoms, Contact, Damping, Dissipation, Force, Gravity, LagrangianSystem, MassMatrix, Potential, Spring, time,
    velocity)
from .models.rigidbody import (  # noqa: E402
    Inertia, RigidBody, angular_momentum, angular_velocity, body_point, quaternion_rate, rotation, unit_norm)
from .models.control import Control  # noqa: E402
from .models.multibody import Multibody  # noqa: E402
from .models.model_files import load_mjcf, load_urdf  # noqa: E402
from .solve.optimal_control import OptimalControl  # noqa: E402
from .solve.contact.options import ContactControlOptions  # noqa: E402
from .solve.simulate import simulate  # noqa: E402

__all__ = ["LagrangianSystem", "Atoms", "MassMatrix", "Gravity", "Spring", "Potential", "Contact", "RigidBody",
           "Inertia", "Force", "Dissipation", "Damping", "time", "velocity", "schemes", "simulate",
           "rotation", "body_point", "unit_norm", "quaternion_rate", "angular_velocity", "angular_momentum",
           "Control", "OptimalControl", "ContactControlOptions", "Multibody", "load_mjcf", "load_urdf"]


def schemes() -> dict:
    """Every discrete Lagrangian on offer, name -> order of accuracy (``simulate``'s ``scheme``, every
    scene's ``--scheme``): ``midpoint`` and the Gauss family ``gauss4 … gauss24``, ``trapezoid``,
    ``galerkin4`` and the Lobatto family ``galerkin6 … galerkin24`` (Lobatto IIIA–IIIB, order ``2r``).

    >>> import castrajectory as ct
    >>> ct.schemes()["midpoint"], ct.schemes()["galerkin4"], ct.schemes()["galerkin10"]
    (2, 4, 10)
    """
    from .discretise.schemes import listing
    return listing()


class _Package(types.ModuleType):
    """The package keeps its public names: importing an old flat module whose name is also a public
    function (``castrajectory.simulate``) binds the module in ``sys.modules`` but must not replace
    ``castrajectory.simulate``, the function, as the import system would (``ct.simulate(...)`` then raised
    "'module' object is not callable" in any process that had imported the old name)."""

    def __setattr__(self, name, value):
        if isinstance(value, types.ModuleType) and name in __all__ and not isinstance(self.__dict__.get(name),
                                                                                         types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


def __getattr__(name):
    if name in _MOVED:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
