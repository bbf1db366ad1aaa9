"""What every kind of measurement is: the seam that lets a new instrument be one new file.

A measurement kind turns one record (what an instrument read at one joint vector) into standardised residuals
and their derivatives: `residuals` and `residual_jacobians` evaluate a batch of records against the model, the
weights come from the instrument's σ (`weights`), the kind's own unknowns (an instrument frame, an anchor, a
length offset) are declared by `unknowns`, and pose design takes the rows a candidate pose would contribute
from `information`. The record's columns after the joints are `columns` (the campaign's CSV layout).

Identification, identifiability, pose design and validation ask the kind; none of them tests which kind it is.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.campaign import Campaign
from models.description.parameters import ParameterSpec
from models.description.robot import RobotDescription
from models.engine.batch import BatchFunctions
from models.measurement import MeasurementKind
from models.noise import NoiseModel

Index = NDArray[np.intp]
"""Which records of a campaign (row numbers)."""


@dataclass(frozen=True)
class ModelBatch:
    """The model at a batch of records: what every kind's residual is evaluated from."""

    functions: BatchFunctions
    """The structure's compiled Functions."""
    q: Array
    """(n, n_joints) the records' joints."""
    theta: Array
    """The parameters."""
    platforms: Array
    """(n, n_platform) the solved closures' unknowns at those joints."""
    conditions: Array | None
    """(n, 7) the model terms' inputs, None without terms."""


class Measurement(Protocol):
    """One kind of measurement (see the module docstring). Internal units: mm and rad."""

    @property
    def kind(self) -> MeasurementKind: ...
    @property
    def rows(self) -> int:
        """Equations per record."""
        ...

    @property
    def label(self) -> str:
        """For messages: "full-pose", "position-only"."""
        ...

    @property
    def columns(self) -> tuple[str, ...]:
        """The record's measured columns, in the campaign's CSV order (after the joints)."""
        ...

    def unknowns(self, desc: RobotDescription) -> tuple[ParameterSpec, ...]:
        """The kind's own unknowns, identified with the robot's parameters (none for a tracker: its frame is the
        robot's `base`)."""
        ...

    def weights(self, noise: NoiseModel, sigma_mm: Array | None, n: int) -> Array:
        """(n, rows) 1/σ per record and residual row; `sigma_mm` (n,) each record's own position σ, or None."""
        ...

    def residuals(self, model: ModelBatch, campaign: Campaign, index: Index) -> Array:
        """(n, rows) model minus measurement of the records `index` (unweighted)."""
        ...

    def residual_jacobians(self, model: ModelBatch, campaign: Campaign, index: Index) -> tuple[Array, Array]:
        """((n, rows) residuals, (n, rows, P) their derivatives by the parameters), unweighted."""
        ...

    def information(self, pose_jacobians: Array, noise: NoiseModel) -> Array:
        """(N, rows, P) the weighted rows a candidate pose contributes, from its TCP pose Jacobians (N, 6, P)
        (world-frame position and small rotation): what design and identifiability stack."""
        ...
