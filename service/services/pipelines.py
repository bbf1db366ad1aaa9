"""One pipeline per operation: a campaign's records of any kinds, as the models fit (calibrate), check and
evaluate (validate) them.

The operations convert their records once (`fitting_in`) and ask the result; none of them asks which kinds the
campaign holds. What each kind contributes is its kind's (`service.record_kinds`: a record's group, its values,
its σ, its notes). The one choice made here is by a declared capability, never by a kind's name: where every
record is of one kind whose records make a whole campaign of the models (`RecordKind.measurement_kinds`, a
tracker's pose or position campaign), the models' specialised pipeline for such a campaign takes them
(`models.identification.identify`: orientations, the instrument's drift, model terms, a fleet prior, structural
identifiability, and one compiled residual over the whole campaign, several times faster than groups); any
other campaign goes to the models as groups by the reference each record measures
(`models.identification.reference_result`), a tracker's positions one group among the others.
"""

# ruff: noqa: ARG002, ARG003  (each way of fitting implements the whole interface, whatever it uses of it)
from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any, cast

from models import RobotDescription
from models._types import Array
from models.campaign import Campaign
from models.engine.runtime import Runtime
from models.errors import InvalidInput
from models.evaluation.accuracy import AccuracyReport, evaluate
from models.evaluation.checks import CheckOptions, CheckResult, check_references, check_version
from models.identifiability import structural_identifiability
from models.identification import IdentificationOptions, IdentificationResult, identify
from models.identification.drift import DriftOptions, identify_with_drift
from models.identification.reference_fit import check_version as check_against_references
from models.identification.reference_result import expected_rank, identify_reference_campaign
from models.identification.terms_check import unused_temperature_note
from models.measurement import MeasurementKind
from models.measurements.references import ReferenceRecords
from models.noise import NoiseModel
from service.conversions.calibrations import records_in
from service.conversions.drift import drift_out, timeline_in
from service.conversions.references import reference_groups_in
from service.errors import BadRequest
from service.record_kinds import RECORD_KINDS, Described, Record, sole_kind
from service.schemas.calibrations import CalibrationCreate
from service.schemas.common import Payload

WHOLE_KINDS = ", ".join(name for name, kind in RECORD_KINDS.items() if kind.whole_campaign)
"""The kinds whose records alone make a whole campaign of the models (for messages: "tracker")."""
GROUPED_KINDS = ", ".join(name for name, kind in RECORD_KINDS.items() if not kind.whole_campaign)
"""The kinds fitted with their references (for messages)."""


class Fitting(ABC):
    """A campaign's records as the models take them: what every operation asks of them."""

    @property
    @abstractmethod
    def kind(self) -> MeasurementKind:
        """What the campaign measured, as the documents state it (`measurement`)."""

    @property
    @abstractmethod
    def size(self) -> int:
        """Its records (`measurements`)."""

    @classmethod
    @abstractmethod
    def refuse_options(cls, body: CalibrationCreate) -> None:
        """A 4xx for each calibration option records fitted this way cannot serve (nothing is silently ignored),
        before anything is converted."""

    @classmethod
    @abstractmethod
    def of(
        cls,
        desc: RobotDescription,
        measurements: Sequence[Any],
        described: Described,
        *,
        sigma_mm: float | None,
        payload: Payload | None,
    ) -> Fitting:
        """The records converted (internal units; `sigma_mm` a record's σ where it states none, None: the noise
        model's); a 4xx naming what is wrong with them."""

    @abstractmethod
    def identify(
        self,
        desc: RobotDescription,
        body: CalibrationCreate,
        *,
        noise: NoiseModel,
        nominal: Array,
        options: IdentificationOptions,
        runtime: Runtime,
    ) -> tuple[IdentificationResult, dict[str, Any] | None]:
        """The identification (with the instrument's drift fitted where asked: the report's `drift`)."""

    @abstractmethod
    def rank(self, desc: RobotDescription, candidates: tuple[int, ...], *, runtime: Runtime) -> int:
        """How many of `candidates` a generic campaign of these records identifies (the acceptance check's)."""

    @abstractmethod
    def check(
        self,
        desc: RobotDescription,
        values: Array,
        covariance: Array,
        *,
        noise: NoiseModel,
        options: CheckOptions,
        runtime: Runtime,
    ) -> CheckResult:
        """A quick check of the version `values` against these records."""

    @abstractmethod
    def evaluate(
        self, version: int, model: RobotDescription, values: Array, *, register: bool, runtime: Runtime
    ) -> AccuracyReport:
        """What each record misses by under version `version` (`values` on its own `model`): a validation's."""


@dataclass(frozen=True)
class WholeCampaign(Fitting):
    """Records that make one campaign of the models (`RecordKind.measurement_kinds`)."""

    campaign: Campaign
    records: Sequence[Record]

    @property
    def kind(self) -> MeasurementKind:
        return self.campaign.kind

    @property
    def size(self) -> int:
        return self.campaign.size

    @classmethod
    def refuse_options(cls, body: CalibrationCreate) -> None:
        return None  # the whole campaign's pipeline serves every option

    @classmethod
    def of(
        cls,
        desc: RobotDescription,
        measurements: Sequence[Any],
        described: Described,
        *,
        sigma_mm: float | None,
        payload: Payload | None,
    ) -> Fitting:
        records = cast(list[Record], list(measurements))
        return cls(records_in(desc, records, default_sigma_mm=sigma_mm, payload=payload), records)

    def identify(
        self,
        desc: RobotDescription,
        body: CalibrationCreate,
        *,
        noise: NoiseModel,
        nominal: Array,
        options: IdentificationOptions,
        runtime: Runtime,
    ) -> tuple[IdentificationResult, dict[str, Any] | None]:
        if body.options.drift is None:
            result = identify(desc, self.campaign, noise=noise, nominal=nominal, options=options, runtime=runtime)
            drift = None
        else:
            fitted = identify_with_drift(
                desc,
                self.campaign,
                timeline_in(desc, self.records, self.campaign),
                drift=DriftOptions(body.options.drift.driver, body.options.drift.degree),
                noise=noise,
                nominal=nominal,
                options=options,
                runtime=runtime,
            )
            result, drift = fitted.result, drift_out(fitted.drift)
        unused = unused_temperature_note(desc, self.campaign.conditions)
        return (result if unused is None else replace(result, notes=(*result.notes, unused))), drift

    def rank(self, desc: RobotDescription, candidates: tuple[int, ...], *, runtime: Runtime) -> int:
        return structural_identifiability(desc, candidates, self.campaign.kind, runtime=runtime).rank

    def check(
        self,
        desc: RobotDescription,
        values: Array,
        covariance: Array,
        *,
        noise: NoiseModel,
        options: CheckOptions,
        runtime: Runtime,
    ) -> CheckResult:
        return check_version(desc, values, covariance, self.campaign, noise=noise, options=options, runtime=runtime)

    def evaluate(
        self, version: int, model: RobotDescription, values: Array, *, register: bool, runtime: Runtime
    ) -> AccuracyReport:
        if register and self.campaign.size < 3:
            raise InvalidInput("register: fitting the instrument frame needs at least 3 records", field="register")
        return evaluate(model, values, self.campaign, register=register, runtime=runtime)


@dataclass(frozen=True)
class RecordGroups(Fitting):
    """Records grouped by the reference each measures (a tracker's positions one group among them)."""

    groups: tuple[ReferenceRecords, ...]
    notes: tuple[str, ...]
    records: int

    @property
    def kind(self) -> MeasurementKind:
        return MeasurementKind.POSITION  # every record's error is stated in mm

    @property
    def size(self) -> int:
        return self.records

    @classmethod
    def of(
        cls,
        desc: RobotDescription,
        measurements: Sequence[Any],
        described: Described,
        *,
        sigma_mm: float | None,
        payload: Payload | None,
    ) -> Fitting:
        sigma = NoiseModel().position_mm if sigma_mm is None else sigma_mm
        groups, notes = reference_groups_in(desc, measurements, described, sigma_mm=sigma)
        return cls(groups, tuple(notes), len(measurements))

    @classmethod
    def refuse_options(cls, body: CalibrationCreate) -> None:
        if body.options.prior == "fleet":
            raise InvalidInput(
                f"options.prior fleet calibrates from {WHOLE_KINDS} records alone: {GROUPED_KINDS} records are "
                "fitted with their references, which take no prior yet; leave out options.prior",
                field="options.prior",
            )
        if body.options.drift is not None:
            raise BadRequest(
                f"options.drift needs {WHOLE_KINDS} records alone (positions in the instrument's frame): records "
                "fitted with their references carry no frame that could drift; calibrate them without "
                "options.drift"
            )
        if body.options.terms:
            raise BadRequest(
                f"options.terms {body.options.terms} need {WHOLE_KINDS} records alone: records fitted with their "
                "references carry no temperature or load per record yet; calibrate the geometry from them "
                "without terms"
            )

    def identify(
        self,
        desc: RobotDescription,
        body: CalibrationCreate,
        *,
        noise: NoiseModel,
        nominal: Array,
        options: IdentificationOptions,
        runtime: Runtime,
    ) -> tuple[IdentificationResult, dict[str, Any] | None]:
        result = identify_reference_campaign(
            desc, self.groups, noise=noise, nominal=nominal, options=options, runtime=runtime
        )
        return replace(result, notes=(*self.notes, *result.notes)), None

    def rank(self, desc: RobotDescription, candidates: tuple[int, ...], *, runtime: Runtime) -> int:
        fixes_frame = any(g.reference.traits.fixes_frame for g in self.groups)
        return expected_rank(desc, candidates, fixes_frame=fixes_frame, runtime=runtime)

    def check(
        self,
        desc: RobotDescription,
        values: Array,
        covariance: Array,
        *,
        noise: NoiseModel,
        options: CheckOptions,
        runtime: Runtime,
    ) -> CheckResult:
        return check_references(desc, values, covariance, self.groups, noise=noise, options=options, runtime=runtime)

    def evaluate(
        self, version: int, model: RobotDescription, values: Array, *, register: bool, runtime: Runtime
    ) -> AccuracyReport:
        """The references placed under that version, the robot held (`reference_fit.check_version`): placing
        them is the registration, so `register` asks nothing more."""
        if model.terms.any:
            raise InvalidInput(
                f"version {version} was calibrated with model terms, which need tracker records (their temperatures "
                "and loads) to be evaluated",
                field="versions",
            )
        check = check_against_references(model, self.groups, values, runtime=runtime)
        return AccuracyReport(check.errors_mm, None, registered=True, iso_poses=(), iso_distances=())


def fitting_for(measurements: Sequence[Any]) -> type[Fitting]:
    """How a campaign's records are fitted: as a whole campaign where every record is of one kind whose records
    make one (`RecordKind.whole_campaign`), as groups by reference otherwise (the module docstring)."""
    whole = sole_kind(measurements)
    return WholeCampaign if whole is not None and whole.whole_campaign else RecordGroups


def fitting_in(
    desc: RobotDescription,
    measurements: Sequence[Any],
    described: Described,
    *,
    sigma_mm: float | None,
    payload: Payload | None = None,
) -> Fitting:
    """A campaign's records as the models take them (`fitting_for`, `Fitting.of`)."""
    return fitting_for(measurements).of(desc, measurements, described, sigma_mm=sigma_mm, payload=payload)
