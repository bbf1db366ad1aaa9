"""The model terms at the boundary: which terms a request asks for, the conditions of records and requests, and
which terms a stored parameter version carries.

A version of a robot with terms stores the terms' values after the geometric ones (`RobotDescription` order);
the count tells which terms they are (thermal adds one value per leg set and prismatic axes, compliance six),
so the stored rows need no new column.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from models import RobotDescription
from models._types import Array
from models.description.terms import Conditions, ModelTerms, make_conditions
from models.errors import InvalidInput
from service.record_kinds.tracker import Record
from service.schemas.common import Payload

_COMBINATIONS = (ModelTerms(thermal=True), ModelTerms(compliance=True), ModelTerms(thermal=True, compliance=True))


def stored_model(desc: RobotDescription, n_values: int) -> RobotDescription:
    """The description a stored version of `n_values` values belongs to: `desc` with the terms they carry."""
    if n_values == desc.n_params:
        return desc
    for terms in _COMBINATIONS:
        try:
            candidate = desc.with_terms(terms)
        except InvalidInput:
            continue
        if candidate.n_params == n_values:
            return candidate
    raise ValueError(f"a stored version of {n_values} values fits no model of this robot ({desc.n_params})")


def requested_model(desc: RobotDescription, names: Sequence[str]) -> RobotDescription:
    """The robot with the terms of `options.terms`; 422 naming the field when a term has nothing to act on."""
    geometric = desc.geometric
    if not names:
        return geometric
    try:
        chosen = geometric.with_terms(ModelTerms(thermal="thermal" in names, compliance="compliance" in names))
    except InvalidInput as exc:
        raise InvalidInput(str(exc), field="options.terms", value=exc.value) from exc
    # A stored version tells its terms by its count of values (`stored_model`): refuse the rare robot whose
    # terms would be told apart by nothing else (one prismatic axis and one revolute joint, no hexapod).
    for terms in _COMBINATIONS:
        if terms.names != chosen.terms.names:
            try:
                other = geometric.with_terms(terms)
            except InvalidInput:
                continue
            if other.n_params == chosen.n_params:
                raise InvalidInput(
                    f"on this robot the terms {list(chosen.terms.names)} and {list(terms.names)} have the same "
                    "number of parameters, which its stored versions cannot tell apart: calibrate with both terms",
                    field="options.terms",
                )
    return chosen


def start_values(desc: RobotDescription, stored: Array) -> Array:
    """A start vector for `desc` from a stored version: its geometric values, and its terms' values where the
    version has the same terms (nominal otherwise)."""
    n_geo = desc.geometric.n_params
    if stored.size == desc.n_params:
        return stored.copy()
    out = desc.parameters.nominal.copy()
    out[:n_geo] = stored[:n_geo]
    return out


def padded(values: list[float | None] | list[bool], n: int, fill: float | bool | None) -> list[float | None]:
    """A stored per-parameter list (std errors, identifiable flags) cut or extended to n entries."""
    return [*list(values)[:n], *([fill] * max(0, n - len(values)))]


def _payload_arrays(payloads: Sequence[Payload | None]) -> tuple[Array, Array]:
    mass = np.array([p.mass_kg if p is not None else 0.0 for p in payloads], dtype=float)
    cog = np.array([p.cog_mm if p is not None else [0.0, 0.0, 0.0] for p in payloads], dtype=float)
    return mass, cog


def record_conditions(desc: RobotDescription, records: Sequence[Record], payload: Payload | None) -> Conditions | None:
    """What the records were measured under; 422 naming the record's field a term needs and it lacks.

    Temperatures count only when every record has one (the thermal term requires them); a payload is the
    record's own or the campaign's."""
    n = len(records)
    temps = [r.temperature_c for r in records]
    missing_t = [i for i, t in enumerate(temps) if t is None]
    if desc.terms.thermal and missing_t:
        raise InvalidInput(
            f"record {missing_t[0]}: the thermal term needs every record's temperature_c (°C); "
            f"{len(missing_t)} of {n} have none",
            field=f"measurements[{missing_t[0]}].temperature_c",
        )
    loads = [r.payload if r.payload is not None else payload for r in records]
    missing_p = [i for i, p in enumerate(loads) if p is None]
    if desc.terms.compliance and missing_p:
        raise InvalidInput(
            f"record {missing_p[0]}: the compliance term needs a payload (the campaign's or the record's own)",
            field="payload" if payload is None and len(missing_p) == n else f"measurements[{missing_p[0]}].payload",
        )
    temperature = None if missing_t else np.array(temps, dtype=float)
    if temperature is None and len(missing_p) == n:
        return None
    if len(missing_p) == n:
        return make_conditions(n, temperature)
    mass, cog = _payload_arrays(loads)  # a record without any payload carries none (0 kg)
    return make_conditions(n, temperature, mass, cog)


def design_levels(
    desc: RobotDescription, temperatures: Sequence[float] | None, payloads: Sequence[Payload] | None
) -> Conditions | None:
    """The conditions a design may choose from: every temperature level with every payload level (the reference
    temperature, or no payload, where one kind is not given); 422 naming the field without the terms."""
    if temperatures is None and payloads is None:
        return None
    if not desc.terms.any:
        field = "temperature_levels_c" if temperatures is not None else "payload_levels"
        raise InvalidInput(f"{field}: levels need the model terms they act on (give terms)", field=field)
    temps = list(temperatures) if temperatures is not None else [desc.terms.reference_temperature_c]
    loads: list[Payload | None] = list(payloads) if payloads is not None else [None]
    pairs = [(t, p) for t in temps for p in loads]
    mass, cog = _payload_arrays([p for _, p in pairs])
    return make_conditions(len(pairs), [t for t, _ in pairs], mass, cog)


def request_conditions(
    n: int, temperature_c: float | Sequence[float] | None, payload: Payload | None
) -> Conditions | None:
    """The conditions of n joint vectors (targets) of a kinematics request: one temperature or one per row."""
    if temperature_c is None and payload is None:
        return None
    temps: Array | None = None
    if temperature_c is not None:
        temps = np.atleast_1d(np.asarray(temperature_c, dtype=float))
        if temps.size not in (1, n):
            raise InvalidInput(
                f"temperature_c: give one temperature or one per row ({n}), not {temps.size}",
                field="temperature_c",
            )
    if payload is None:
        return make_conditions(n, temps)
    return make_conditions(n, temps, payload.mass_kg, payload.cog_mm)
