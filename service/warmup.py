"""Build every CasADi Function and solver once, at start-up, so no request pays for it."""

from __future__ import annotations

from models import iwr, sample_workspace
from models.compensation import inverse_kinematics
from models.compensation.kkt import kkt_functions
from models.compensation.nlp import ik_solvers
from models.identification import identify
from models.kinematics import forward_kinematics
from models.simulation import measure, perturbed_robot
from models.transforms import matrix_to_quaternion


def warm_up() -> None:
    desc = iwr()
    ik_solvers(desc)
    kkt_functions(desc)
    sim = perturbed_robot(desc, seed=0)
    result = identify(desc, measure(sim, sample_workspace(desc, 30, seed=0), seed=0))
    fk = forward_kinematics(desc, sample_workspace(desc, 2, seed=1), result.parameters)
    inverse_kinematics(desc, fk.positions, matrix_to_quaternion(fk.rotations), result.parameters)
