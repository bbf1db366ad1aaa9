"""A serial stage: DH or MDH links, each revolute, prismatic or fixed (robots.md "Serial stage")."""

from __future__ import annotations

import math
from collections.abc import Hashable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from models._types import Array
from models.description.parameters import Kind, ParameterScales, ParameterSpec
from models.description.serial_chain import (
    Convention,
    DHLink,
    JointType,
    chain_transform,
    dh_parameter_specs,
    is_nearly_parallel,
)
from models.errors import InvalidInput
from models.stages.base import Section, WithoutClosure
from models.stages.document import DEG, interval, mapping, number
from models.transforms import Sym

CONVENTIONS = tuple(c.value for c in Convention)
JOINT_TYPES = tuple(j.value for j in JointType)
_KEYS = {"kind", "convention", "links"}
_LINK_KEYS = {"joint", "a", "alpha", "d", "theta", "beta", "range"}


@dataclass(frozen=True)
class SerialStage(WithoutClosure):
    """Links in order; its joints are the moving links' readings, its parameters the links' DH numbers."""

    links: tuple[DHLink, ...]

    kind: ClassVar[str] = "serial"
    section: ClassVar[Section] = Section.LINKS
    group: ClassVar[str] = "links"
    classic_group: ClassVar[str] = "carriage"

    @property
    def moving_links(self) -> tuple[DHLink, ...]:
        return tuple(link for link in self.links if link.joint.moves)

    @property
    def n_joints(self) -> int:
        return sum(link.joint.moves for link in self.links)

    @property
    def n_params(self) -> int:
        return sum(link.n_params for link in self.links)

    @property
    def n_items(self) -> int:
        return len(self.links)

    @property
    def token(self) -> Hashable:
        return tuple(link.token for link in self.links)

    @property
    def moves(self) -> bool:
        return self.n_joints > 0

    @property
    def dh_links(self) -> tuple[DHLink, ...]:
        return self.links

    def joint_names(self, first: int) -> tuple[str, ...]:
        return tuple(f"q{first + k}" for k in range(self.n_joints))

    def joint_kinds(self) -> tuple[Kind, ...]:
        return tuple(link.joint.kind for link in self.moving_links)

    def joint_limits(self) -> tuple[Array, Array]:
        moving = self.moving_links
        return np.array([lk.joint_min for lk in moving], dtype=float), np.array([lk.joint_max for lk in moving])

    def parameter_specs(self, first: int, scales: ParameterScales, group: str) -> list[ParameterSpec]:
        return dh_parameter_specs(self.links, scales.dh_length, scales.dh_angle, group, first)

    def transform(self, q: Sym, x: Sym, p: Sym) -> Sym:
        return chain_transform(self.links, q, p)

    def usable(self, q: Array, x: Array, p: Array) -> Array:
        lo, hi = self.joint_limits()
        return np.asarray(np.all((q >= lo) & (q <= hi), axis=1))

    def document(self, p: Array) -> dict[str, Any]:
        links = []
        at = 0
        for link in self.links:
            row: dict[str, Any] = {"joint": link.joint.value}
            for k, f in enumerate(link.fields):
                value = float(p[at + k])
                row[f] = value if f in ("a", "d") else math.degrees(value)
            at += link.n_params
            if link.joint.moves:
                scale = 1.0 if link.joint is JointType.PRISMATIC else math.degrees(1.0)
                row["range"] = [link.joint_min * scale, link.joint_max * scale]
            links.append(row)
        conventions = {link.convention for link in self.links}
        return {"kind": self.kind, "convention": conventions.pop().value, "links": links}


def read_serial(raw: Mapping[str, Any], where: str) -> SerialStage:
    """robots.md's serial stage (see `models.stages.base.StageReader`)."""
    mapping(raw, where, _KEYS)
    convention = raw.get("convention")
    if convention not in CONVENTIONS:
        raise InvalidInput(
            f"unknown convention {convention!r}",
            field=f"{where}.convention",
            value=str(convention),
            allowed=list(CONVENTIONS),
        )
    links = raw.get("links")
    if not isinstance(links, list) or not links:
        raise InvalidInput("a serial stage needs a non-empty list of links", field=f"{where}.links")
    return SerialStage(
        tuple(_link(link, Convention(convention), f"{where}.links[{k}]") for k, link in enumerate(links))
    )


def _link(link: object, convention: Convention, where: str) -> DHLink:
    raw = mapping(link, where, _LINK_KEYS)
    joint = raw.get("joint")
    if joint not in JOINT_TYPES:
        raise InvalidInput(
            f"unknown joint type {joint!r}", field=f"{where}.joint", value=str(joint), allowed=list(JOINT_TYPES)
        )
    kind = JointType(joint)
    values = {k: number(raw.get(k, 0.0), f"{where}.{k}") for k in ("a", "alpha", "d", "theta")}
    alpha = values["alpha"] * DEG
    beta = 0.0
    if "beta" in raw:
        # robots.md gives mdh links with parallel axes their beta; dh links with parallel axes may carry one too
        # (an addition, README "Any robot"), which puts them in Hayati's form.
        if not is_nearly_parallel(alpha):
            raise InvalidInput(
                "beta belongs only to links whose axis is parallel to the next (dh) or previous (mdh) one "
                "(alpha 0 or ±180°, within 5° for a calibrated twist)",
                field=f"{where}.beta",
            )
        beta = number(raw["beta"], f"{where}.beta") * DEG
    if kind is JointType.FIXED:
        if raw.get("range") is not None:
            raise InvalidInput("a fixed link has no joint, so no range", field=f"{where}.range")
        lo, hi = 0.0, 0.0
    else:
        if "range" not in raw:
            raise InvalidInput("a moving joint needs its range [lo, hi]", field=f"{where}.range")
        lo, hi = interval(raw["range"], f"{where}.range")
        if kind is JointType.REVOLUTE:
            lo, hi = lo * DEG, hi * DEG
    return DHLink(
        kind,
        theta=values["theta"] * DEG,
        d=values["d"],
        a=values["a"],
        alpha=alpha,
        joint_min=lo,
        joint_max=hi,
        convention=convention,
        beta=beta,
        beta_given="beta" in raw,
    )
