"""Warm-up of the inverse-kinematics artefacts of a runtime (`Runtime.warm`)."""

from __future__ import annotations

from models.description.robot import RobotDescription
from models.engine.runtime import Runtime
from models.inverse.kkt import kkt_functions
from models.inverse.nlp import ik_solvers
from models.inverse.starts import start_table


def warm_inverse(desc: RobotDescription, runtime: Runtime) -> None:
    """The KKT Functions, the IPOPT NLPs and the start table of the nominal model."""
    kkt_functions(desc, runtime)
    ik_solvers(desc, runtime)
    start_table(desc, desc.parameters.nominal, runtime)
