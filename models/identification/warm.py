"""Warm-up of the identification artefacts of a runtime (`Runtime.warm`)."""

from __future__ import annotations

from models.description.robot import RobotDescription
from models.engine.runtime import Runtime
from models.identifiability import structural_identifiability
from models.identification.accuracy import ACCURACY_SEED
from models.identification.options import IdentificationOptions
from models.identification.solver import solver_pool
from models.measurement import MeasurementKind
from models.workspace import workspace_samples


def warm_identification(desc: RobotDescription, runtime: Runtime) -> None:
    """The structural subsets of the default estimate, a solver for each of their sizes, the accuracy poses."""
    options = IdentificationOptions()
    candidates = desc.parameters.indices(options.estimate)
    pool = solver_pool(runtime)
    for kind in MeasurementKind:
        rank = structural_identifiability(desc, candidates, kind, runtime=runtime).rank
        pool.prepare(rank, options.max_iterations)
    workspace_samples(desc, options.workspace_samples, ACCURACY_SEED, runtime=runtime)
