"""Compensation: joint commands that put the calibrated robot's TCP on target.

The calibrated model's inverse kinematics (`models.inverse`), and the
correction of a program written against the nominal model.
"""

from __future__ import annotations

from numpy.typing import ArrayLike

from models.compensation.terms import terms_inverse_kinematics
from models.description.robot import RobotDescription
from models.description.terms import Conditions
from models.engine.runtime import Runtime, runtime_for
from models.inverse import IkSolution, inverse_kinematics
from models.kinematics import as_joint_array, check_joint_ranges, forward_kinematics
from models.transforms import matrix_to_quaternion

Compensation = IkSolution
"""A compensation is the inverse kinematics of the calibrated model: joint commands and what they reach."""


def compensate(
    desc: RobotDescription,
    params: ArrayLike,
    positions: ArrayLike,
    quaternions: ArrayLike | None = None,
    *,
    seed: ArrayLike | None = None,
    runtime: Runtime | None = None,
    conditions: Conditions | None = None,
    geometric_runtime: Runtime | None = None,
) -> Compensation:
    """Joint commands reaching the targets on the robot with the calibrated parameters `params`.

    With model terms on, `conditions` are what each target runs under (its temperature, its payload), so a
    compensated program is right at the temperature it runs at (`models.compensation.terms`)."""
    if desc.terms.any:
        return terms_inverse_kinematics(
            desc,
            positions,
            quaternions,
            params,
            conditions=conditions,
            seed=seed,
            runtime=runtime,
            geometric_runtime=geometric_runtime,
        )
    return inverse_kinematics(desc, positions, quaternions, params, seed=seed, runtime=runtime)


def correct_program(
    desc: RobotDescription,
    program: ArrayLike,
    params: ArrayLike,
    nominal: ArrayLike | None = None,
    *,
    runtime: Runtime | None = None,
    conditions: Conditions | None = None,
    geometric_runtime: Runtime | None = None,
) -> Compensation:
    """Corrected joints for a program written against the nominal model.

    Each nominal joint vector promises a TCP pose (the nominal geometry, placed where the calibrated model puts
    the robot's base); the answer reaches those poses on the calibrated robot, seeded with the program's own
    joints so that it changes them as little as possible. With model terms on, the promise is the nominal
    geometry's (at the reference conditions) and the answer holds under `conditions`.
    """
    rt = runtime_for(desc, runtime)
    theta = desc.parameters.vector(params)
    theta_nom = desc.parameters.nominal if nominal is None else desc.parameters.vector(nominal)
    joints = as_joint_array(desc, program)
    check_joint_ranges(desc, joints)
    promised_params = theta_nom.copy()
    promised_params[desc.slices["base"]] = theta[desc.slices["base"]]
    promised = forward_kinematics(desc, joints, promised_params, runtime=rt)
    return compensate(
        desc,
        theta,
        promised.positions,
        matrix_to_quaternion(promised.rotations),
        seed=joints,
        runtime=rt,
        conditions=conditions,
        geometric_runtime=geometric_runtime,
    )
