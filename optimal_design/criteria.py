"""Design criteria on the information matrix M = Σ AᵢᵀAᵢ, and the observability indices of a design.

Every criterion is turned into a utility to maximise (`utility`), so that
rounding and exchange treat them alike; `value` is the natural number users
read (log det, trace of the inverse, smallest eigenvalue, condition number of
the stacked scaled Jacobian, predicted RMS TCP error in mm).

Each criterion is one object (`CRITERIA`, keyed by its `Criterion` name) that
carries everything the relaxation, the rounding and exchange, branch and bound,
the target mode and the service's time estimate need to know about it, so those
modules call its methods instead of asking which criterion they hold. There are
two families, which the algorithms tell apart by their methods, not by name:

- `SmoothCriterion` (D, A, I): concave and differentiable in the weights, so the
  relaxation is first order (`gradient`), swaps have exact low-rank values
  (`swap_values`) and branch and bound applies (`branch_curvature`).
- `SpectralCriterion` (E, condition): functions of the extreme eigenvalues, so
  the relaxation is a semidefinite programme (`homogeneous`, `dual_bound`) and
  swaps are evaluated on the spectrum (`spectral_values`, `ritz_bound`).

A new criterion is a new class here, one member of `Criterion` and one entry in
`CRITERIA` (tests/optimal_design/test_criteria_registry.py checks all three agree
and that the class implements every method); the service's schemas take the
name from `Criterion`, so the committed `service/openapi.json` gains the name too.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from enum import StrEnum
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.errors import InvalidInput
from optimal_design.lowrank import SwapTerms, log_det_bound, trace_bound

if TYPE_CHECKING:
    from optimal_design.information import CandidateInformation


# A criterion's name, as the API spells it (the objects are in CRITERIA). No docstring: pydantic would put it in
# the API schema's description of the enum.
class Criterion(StrEnum):
    D = "D"
    A = "A"
    E = "E"
    CONDITION = "condition"
    I = "I"  # noqa: E741  (the name of the criterion in the literature)

    @classmethod
    def parse(cls, name: str) -> Criterion:
        for c in cls:
            if c.value.lower() == str(name).lower():
                return c
        raise InvalidInput(
            f"unknown criterion {name!r}; choose one of {[c.value for c in cls]}", field="criterion", value=str(name)
        )


GAP_D = 0.01
"""Stop the D iterations when the bound is within this of log det (an efficiency gap of 0.02 % at P = 54)."""
GAP_RELATIVE = 1e-3
CONDITION_D_FLOOR = 0.9
"""The condition design's default D-efficiency floor (README: the plain condition design calibrates the TCP barely
better than random poses, 0.90x at K = 30 of 2 000; kept at D-efficiency >= 0.9 it is 0.69x). Soft: where the
D design itself reaches less, the floor is what it reaches. `d_efficiency_floor=0` turns it off."""


def eigenvalues(m: Array) -> Array:
    return np.asarray(np.linalg.eigvalsh((m + m.T) / 2), dtype=float)


def top_sum(g: Array, k: int) -> float:
    """The sum of the k largest entries."""
    return float(np.partition(g, g.size - k)[g.size - k :].sum()) if k > 0 else 0.0


def bottom_sum(g: Array, k: int) -> float:
    """The sum of the k smallest entries."""
    return float(np.partition(g, k - 1)[:k].sum()) if k > 0 else 0.0


def _traces(info: CandidateInformation, z: Array) -> Array:
    """tr(Z AᵢᵀAᵢ) / tr(Z) for every candidate, through Z's factor: the duals have rank ~9 (the bundle's bases),
    so ‖Aᵢ R‖² with Z = RRᵀ is a product with 9 columns instead of 54."""
    ev, vec = np.linalg.eigh((z + z.T) / 2)
    kept = ev > 1e-14 * max(float(ev[-1]), 1e-300)
    factor = vec[:, kept] * np.sqrt(ev[kept])
    reach = np.square(info.blocks.reshape(-1, info.n_params) @ factor).sum(axis=1)
    return np.asarray(reach.reshape(info.size, info.rows).sum(axis=1) / np.trace(z), dtype=float)


class DesignCriterion(ABC):
    """What every criterion provides; the two families below add their algorithms' hooks."""

    name: Criterion
    summary: str
    """What it makes small, in a user's words (the API lists it: GET /v1/design-criteria)."""
    cost_factor: float
    """Its design time relative to D's (service.compute.limits' estimate): the largest ratio of three runs of the
    library
    at M = 2 000, K = 30 (medians of seeds 1-3, the shared 2-core machine at load 2.5-3.1), rounded up. After the
    dspeed branch: D 0.21 / 0.29 / 0.27 s, A 0.34 / 0.53 / 0.40 s (x1.63 / 1.86 / 1.48), I 0.54 / 0.77 / 0.66 s
    (x2.54 / 2.71 / 2.45), E 0.67 / 1.00 / 0.87 s (x3.16 / 3.50 / 3.23), condition 0.70 / 1.10 / 0.75 s
    (x3.31 / 3.86 / 2.77). (After issue 30, in one run: D 0.72, A 0.87, I 1.28, E 1.72, condition 1.77 s.)"""
    branchable: bool = False
    """Branch and bound (optimal_design.branching) can tighten its certificate."""
    targetable: bool = False
    """The target mode may design with it (it must make the predicted TCP error fall with K)."""
    takes_d_floor: bool = False
    """A D-efficiency floor (`d_efficiency_floor`) may be kept while optimising it."""
    default_d_floor: float | None = None
    """The D-efficiency floor it keeps unless told otherwise (soft: lowered to what the D design reaches)."""
    wide_greedy_exchange: bool = True
    """Whether the exchange from the greedy start may leave the small pool (solve._greedy_start)."""
    proxy_start: bool = False
    """Whether the rounded start is first improved on a smooth proxy (solve._smooth_start)."""
    ranking_reuse: int = 0
    """Swaps for which one ranking of the candidates serves the exchange's small pool before it is redone (0: a
    fresh ranking at every swap; a fresh one and the wide pool always confirm the end)."""

    def utility(self, m: Array, task: Array) -> float:
        """Larger is better; -inf for a singular design."""
        ev = eigenvalues(m)
        if ev[0] <= ev[-1] * 1e-14 or ev[0] <= 0:
            return float("-inf")
        return self._utility(ev, m, task)

    @abstractmethod
    def _utility(self, ev: Array, m: Array, task: Array) -> float:
        """The utility of a non-singular M with eigenvalues `ev` (ascending)."""

    @abstractmethod
    def reading(self, u: float) -> float:
        """The natural number users read, from a utility (of a design or a bound)."""

    def value(self, m: Array, task: Array) -> float:
        """The criterion as users read it (see module docstring)."""
        return self.reading(self.utility(m, task))

    @abstractmethod
    def efficiency(self, design_utility: float, bound: float, n_params: int) -> float:
        """Design against the bound, 1 = as good as the relaxation."""

    @abstractmethod
    def pool_gain(self, info: CandidateInformation, m: Array, pool: NDArray[Any]) -> Array:
        """How much each candidate of `pool` would add to the design of information m (exchange's ranking)."""


class SmoothCriterion(DesignCriterion):
    """A criterion concave and differentiable in the weights: f(M) with ∂f/∂M = `derivative`."""

    branchable = True
    power: float
    """Exponent of the multiplicative update wᵢ ← wᵢ gᵢ^power (relaxation.first_order). The classical 1 (D) and
    1/2 (A, I) are the proven monotone ones; at K = 30 of 2 000 the larger ones used converge in 92 (D), 87 (A)
    and 126 (I) iterations instead of 272, 257 and 477, to the same bounds; larger still diverged (A at 2, I at
    3). Any drop of the objective after a multiplicative step halves the exponent (until a rounding-level drop
    after the working set moved was taken for one, every D relaxation ran at half its exponent from the second
    iteration: 172 iterations instead of 87 at K = 30 of 2 000), and the certificate never depends on it."""
    newton: bool = False
    """Its relaxation has a projected Newton route (relaxation.newton_d) for the root polish and the leaves."""

    @abstractmethod
    def objective(self, info: CandidateInformation, m: Array, inv: NDArray[Any]) -> float:
        """f(M) (the utility, without the singularity test), given inv = M⁻¹."""

    @abstractmethod
    def derivative(self, info: CandidateInformation, inv: NDArray[Any]) -> Array:
        """∂f/∂M, given inv = M⁻¹: the matrix Q with ∂f/∂wᵢ = tr(Q AᵢᵀAᵢ)."""

    def gradient(self, info: CandidateInformation, m: Array, index: NDArray[Any] | None = None) -> tuple[float, Array]:
        """(f(M), ∂f/∂wᵢ); `index` restricts the gradient to some candidates (the working set)."""
        inv = np.linalg.inv(m)
        return self.objective(info, m, inv), info.quadratic(self.derivative(info, inv), index)

    @abstractmethod
    def tolerance(self, f: float) -> float:
        """The certificate gap at which the first-order relaxation stops."""

    @abstractmethod
    def swap_values(self, info: CandidateInformation, terms: SwapTerms) -> Array:
        """Utility after each swap (design pose a out, pool candidate j in), (I, J), from the r × r systems
        the swaps share (optimal_design.lowrank); −inf where the swapped design is singular."""

    def swap_bound(
        self, info: CandidateInformation, design: NDArray[Any], pool: NDArray[Any], *, m: Array, above: float
    ) -> Array:
        """An upper bound of `swap_values` (I, J), much cheaper than them, tight where it may exceed `above`:
        exchange._swap_values_lowrank evaluates only the swaps whose bound exceeds what it asks for.

        First the concave criterion's tangent, f(M') ≤ f(M) + tr(∂f/∂M (Fⱼ − Fₐ)), a sum of one number per
        candidate and one per design pose; then, for the candidates that tangent cannot rule out, the family's
        tighter `pair_bound`."""
        inv = np.linalg.inv(m)
        g = info.quadratic(self.derivative(info, inv), np.concatenate([design, pool]))
        tangent = self.objective(info, m, inv) + g[None, design.size :] - g[: design.size, None]
        open_ = np.flatnonzero(tangent.max(axis=0) > above - 1e-9 * max(1.0, abs(above)))
        if open_.size:
            tangent[:, open_] = np.minimum(tangent[:, open_], self.pair_bound(info, design, pool[open_], inv=inv))
        return np.asarray(tangent)

    @abstractmethod
    def pair_bound(
        self, info: CandidateInformation, design: NDArray[Any], pool: NDArray[Any], *, inv: NDArray[Any]
    ) -> Array:
        """An upper bound of `swap_values` (I, J) from a few matrix products (optimal_design.lowrank)."""

    @abstractmethod
    def branch_curvature(self, info: CandidateInformation, inv: NDArray[Any], rows: Array, near: Array) -> Array:
        """−∂²f/∂wᵢ∂wⱼ per pair of rows (`rows` the fractional candidates' rows, near = rows M⁻¹ rowsᵀ)."""

    def pool_gain(self, info: CandidateInformation, m: Array, pool: NDArray[Any]) -> Array:
        # First-order gain of adding the candidate: tr(∂f/∂M · AᵀA). The plain variance function ranked A swaps
        # badly: with it the A exchange fell back to the wide pool in most of its 44 swaps (5.7 s at K = 30 of
        # 2 000).
        return info.quadratic(self.derivative(info, np.linalg.inv(m)), pool)


class DOptimal(SmoothCriterion):
    name = Criterion.D
    summary = "the identified parameters' joint uncertainty (the volume of their confidence ellipsoid)"
    cost_factor = 1.0
    # Scoring every candidate at every swap was half of the D exchange's time; the same designs at K = 30 of
    # 2 000 (seeds 1-5). A and I took other paths with it (seed 2: efficiency 0.9598 -> 0.9591 and 0.928 -> 0.926).
    ranking_reuse = 4
    targetable = True
    power = 3.0
    newton = True

    def _utility(self, ev: Array, m: Array, task: Array) -> float:
        return float(np.sum(np.log(ev)))

    def reading(self, u: float) -> float:
        return u

    def efficiency(self, design_utility: float, bound: float, n_params: int) -> float:
        # per-parameter geometric mean
        return float(math.exp((design_utility - bound) / n_params))

    def objective(self, info: CandidateInformation, m: Array, inv: NDArray[Any]) -> float:
        return float(np.linalg.slogdet(m)[1])

    def derivative(self, info: CandidateInformation, inv: NDArray[Any]) -> Array:
        return inv

    def tolerance(self, f: float) -> float:
        return GAP_D

    def swap_values(self, info: CandidateInformation, terms: SwapTerms) -> Array:
        return terms.log_det()

    def pair_bound(
        self, info: CandidateInformation, design: NDArray[Any], pool: NDArray[Any], *, inv: NDArray[Any]
    ) -> Array:
        return log_det_bound(info.blocks[design], info.blocks[pool], inv)

    def branch_curvature(self, info: CandidateInformation, inv: NDArray[Any], rows: Array, near: Array) -> Array:
        return np.asarray(near * near)  # ∂²/∂wᵢ∂wⱼ log det M = −tr(M⁻¹FᵢM⁻¹Fⱼ)


class TraceCriterion(SmoothCriterion):
    """−tr(L M⁻¹) for a fixed weight matrix L (`weight`)."""

    @abstractmethod
    def weight(self, task: Array, p: int) -> Array:
        """L, from the task matrix and the number of parameters."""

    def _utility(self, ev: Array, m: Array, task: Array) -> float:
        return -float(np.trace(self.weight(task, m.shape[0]) @ np.linalg.inv(m)))

    def objective(self, info: CandidateInformation, m: Array, inv: NDArray[Any]) -> float:
        return -float(np.trace(self.weight(info.task, m.shape[0]) @ inv))

    def derivative(self, info: CandidateInformation, inv: NDArray[Any]) -> Array:
        return np.asarray(inv @ self.weight(info.task, inv.shape[0]) @ inv)

    def tolerance(self, f: float) -> float:
        return GAP_RELATIVE * abs(f)

    def efficiency(self, design_utility: float, bound: float, n_params: int) -> float:
        return float(bound / design_utility)  # both negative

    def swap_values(self, info: CandidateInformation, terms: SwapTerms) -> Array:
        return np.asarray(-terms.trace(self.weight(info.task, info.n_params)))

    def pair_bound(
        self, info: CandidateInformation, design: NDArray[Any], pool: NDArray[Any], *, inv: NDArray[Any]
    ) -> Array:
        weight = self.weight(info.task, info.n_params)
        return np.asarray(-trace_bound(info.blocks[design], info.blocks[pool], inv, weight))

    def branch_curvature(self, info: CandidateInformation, inv: NDArray[Any], rows: Array, near: Array) -> Array:
        # ∂²/∂wᵢ∂wⱼ (−tr LM⁻¹) = −2 tr(M⁻¹LM⁻¹ Fᵢ M⁻¹ Fⱼ), symmetrised
        far = rows @ (inv @ self.weight(info.task, info.n_params) @ inv) @ rows.T
        return np.asarray(near * far + (near * far).T)


class AOptimal(TraceCriterion):
    name = Criterion.A
    summary = "the identified parameters' mean variance"
    cost_factor = 1.9
    power = 1.5

    def weight(self, task: Array, p: int) -> Array:
        return np.eye(p)

    def _utility(self, ev: Array, m: Array, task: Array) -> float:
        return -float(np.trace(np.linalg.inv(m)))

    def reading(self, u: float) -> float:
        return -u


class IOptimal(TraceCriterion):
    """The mean predicted TCP position variance over the workspace, tr(L M⁻¹) with L the task matrix."""

    name = Criterion.I
    summary = "the predicted TCP position error, averaged over the workspace"
    cost_factor = 2.8
    targetable = True
    power = 2.0

    def weight(self, task: Array, p: int) -> Array:
        return task

    def reading(self, u: float) -> float:
        # predicted RMS TCP error in mm
        return math.sqrt(-u) if u < 0 else 0.0


class SpectralCriterion(DesignCriterion):
    """A function of the extreme eigenvalues: a semidefinite relaxation, and swaps evaluated on the spectrum.

    Its SDP is posed on the weak subspace (and, when `strong_side`, the strong one) of the D relaxation's
    information (relaxation.sdp)."""

    takes_d_floor = True
    # The greedy start is a baseline and a second start; its exchange stays in the small pool (1.3-2 s at K = 30
    # of 2 000 with the wide pool; the rounded start, not this one, is the answer in every benchmark run since
    # the proxy start).
    wide_greedy_exchange = False
    # λ_min is flat almost everywhere, so single spectral swaps from the rounded start stall early
    proxy_start = True
    strong_side: bool = False
    """Its bound needs the strongest directions too (λ_max)."""
    homogeneous: bool = False
    """Its SDP is posed on u = τ·w (relaxation._compressed): maximise s with VᵀM(u)V ⪰ s·I, with UᵀM(u)U ⪯ I when
    `strong_side`, Σu = Kτ, u ≤ τ. Otherwise on w itself: maximise s with VᵀM(w)V ⪰ s·I, Σw = K, w ≤ 1."""

    @abstractmethod
    def spectral_values(self, ev: Array) -> Array:
        """The utility of each design whose ascending eigenvalues are the rows of `ev` (−inf where singular)."""

    @abstractmethod
    def ritz_bound(self, weak: Array, strong: Callable[[], Array]) -> Array:
        """An upper bound of each swap's utility from Rayleigh–Ritz bounds of λ_min (`weak`) and λ_max (`strong`,
        computed only when asked for)."""

    @abstractmethod
    def relaxed_weights(self, raw: Array, tau: float) -> Array:
        """The weights of the SDP's solution `raw` (the variable w, its homogenising τ)."""

    @abstractmethod
    def dual_bound(
        self, info: CandidateInformation, count: int, base: Array, zs: list[Array]
    ) -> tuple[float, NDArray[Any]]:
        """Bound on the utility of every K-subset from PSD density matrices (relaxation's module docstring), and
        the K-subset that attains the bound's inner maximum."""

    def pool_gain(self, info: CandidateInformation, m: Array, pool: NDArray[Any]) -> Array:
        # the candidate's reach along the design's weakest directions
        ev, vec = np.linalg.eigh(m)
        weak = vec[:, :3] / np.sqrt(np.maximum(ev[:3], 1e-300))
        return np.asarray(np.sum((info.blocks[pool] @ weak) ** 2, axis=(1, 2)))


class EOptimal(SpectralCriterion):
    name = Criterion.E
    summary = "the uncertainty of the worst-determined combination of parameters"
    cost_factor = 3.5

    def _utility(self, ev: Array, m: Array, task: Array) -> float:
        return float(ev[0])

    def reading(self, u: float) -> float:
        return u

    def efficiency(self, design_utility: float, bound: float, n_params: int) -> float:
        return float(design_utility / bound)

    def spectral_values(self, ev: Array) -> Array:
        return np.asarray(ev[:, 0])

    def ritz_bound(self, weak: Array, strong: Callable[[], Array]) -> Array:
        return weak

    def relaxed_weights(self, raw: Array, tau: float) -> Array:
        return raw

    def dual_bound(
        self, info: CandidateInformation, count: int, base: Array, zs: list[Array]
    ) -> tuple[float, NDArray[Any]]:
        z = zs[0]
        c = _traces(info, z)
        return float(np.trace(z @ base) / np.trace(z) + top_sum(c, count)), np.argpartition(-c, count - 1)[:count]


class ConditionNumber(SpectralCriterion):
    """The condition number of the stacked scaled Jacobian, √(λ_max/λ_min) of M; utility −cond(J)."""

    name = Criterion.CONDITION
    summary = "the condition number of the identification's scaled Jacobian"
    cost_factor = 3.9
    default_d_floor = CONDITION_D_FLOOR
    strong_side = True
    # Homogenised: the upper spectrum is pinned (UᵀM(u)U ⪯ I) and the lower one pushed up (VᵀM(u)V ⪰ s·I), so
    # cond ≥ scale_high/(s·scale_low) for every K-subset — an exact convex form of the quasi-convex problem that
    # Clarabel solves reliably (the form with a free upper bound t, min t s.t. I ⪯ M(u) ⪯ t·I, fails on these
    # spectra).
    homogeneous = True

    def _utility(self, ev: Array, m: Array, task: Array) -> float:
        return -float(np.sqrt(ev[-1] / ev[0]))

    def reading(self, u: float) -> float:
        return -u

    def efficiency(self, design_utility: float, bound: float, n_params: int) -> float:
        return float(bound / design_utility)  # both negative

    def spectral_values(self, ev: Array) -> Array:
        return np.asarray(np.where(ev[:, 0] > 0, -np.sqrt(ev[:, -1] / ev[:, 0]), -np.inf))

    def ritz_bound(self, weak: Array, strong: Callable[[], Array]) -> Array:
        return np.asarray(np.where(weak > 0, -np.sqrt(strong() / weak), -np.inf))

    def relaxed_weights(self, raw: Array, tau: float) -> Array:
        return raw / max(tau, 1e-300)

    def dual_bound(
        self, info: CandidateInformation, count: int, base: Array, zs: list[Array]
    ) -> tuple[float, NDArray[Any]]:
        z1, z2 = zs
        a, b = _traces(info, z2), _traces(info, z1)
        a0, b0 = np.trace(z2 @ base) / np.trace(z2), np.trace(z1 @ base) / np.trace(z1)
        lo, hi = 0.0, float((a0 + top_sum(a, count)) / max(b0 + bottom_sum(b, count), 1e-300))
        hi = max(hi, 1.0)
        for _ in range(200):
            r = 0.5 * (lo + hi)
            if a0 - r * b0 + bottom_sum(a - r * b, count) <= 0:
                hi = r
            else:
                lo = r
            if hi - lo <= 1e-13 * hi:  # lo, the bound, is then exact to rounding (~45 halvings, not 200)
                break
        ratio = lo  # no K-subset has λ_max/λ_min below this
        chosen = np.argpartition(a - hi * b, count - 1)[:count]
        return -float(np.sqrt(max(ratio, 0.0))), chosen


D_OPTIMAL: SmoothCriterion = DOptimal()
"""D itself, where an algorithm needs log det whatever the criterion (the D-efficiency floor, the SDP's subspaces)."""
I_OPTIMAL: SmoothCriterion = IOptimal()
"""I itself, the predicted RMS TCP error the target mode certifies."""
CRITERIA: Mapping[str, DesignCriterion] = MappingProxyType(
    {c.name: c for c in (D_OPTIMAL, AOptimal(), EOptimal(), ConditionNumber(), I_OPTIMAL)}
)
"""Every criterion, by name (a `Criterion` or its string)."""


def parse(name: str) -> DesignCriterion:
    """The criterion of a name, case-insensitive; InvalidInput naming the choices otherwise."""
    return CRITERIA[Criterion.parse(name)]


def criterion_of(criterion: str | DesignCriterion) -> DesignCriterion:
    """The criterion object of a name (a `Criterion`, or a string `parse` accepts) or of an object."""
    if isinstance(criterion, DesignCriterion):
        return criterion
    found = CRITERIA.get(criterion)
    return found if found is not None else parse(criterion)


def smooth(criterion: str | DesignCriterion) -> SmoothCriterion:
    """The criterion, which must be of the first-order family (relaxation.first_order, low-rank swaps)."""
    c = criterion_of(criterion)
    if not isinstance(c, SmoothCriterion):
        raise ValueError(f"the {c.name.value} criterion has no first-order relaxation")
    return c


def spectral(criterion: str | DesignCriterion) -> SpectralCriterion:
    """The criterion, which must be of the spectral family (relaxation.sdp, spectral swaps)."""
    c = criterion_of(criterion)
    if not isinstance(c, SpectralCriterion):
        raise ValueError(f"the {c.name.value} criterion has no semidefinite relaxation")
    return c


def cost_factor(name: str) -> float:
    """The design time of a criterion relative to D's; an unknown name costs as much as the dearest."""
    found = CRITERIA.get(name)
    return found.cost_factor if found is not None else max(c.cost_factor for c in CRITERIA.values())


def names(where: Callable[[DesignCriterion], bool]) -> list[Criterion]:
    """The names of the criteria for which `where` holds, in registry order."""
    return [c.name for c in CRITERIA.values() if where(c)]


def listing(chosen: list[Criterion]) -> str:
    """'D, A and I'."""
    words = [c.value for c in chosen]
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} and {words[-1]}"


def utility(criterion: str | DesignCriterion, m: Array, task: Array) -> float:
    """Larger is better; -inf for a singular design."""
    return criterion_of(criterion).utility(m, task)


def value(criterion: str | DesignCriterion, m: Array, task: Array) -> float:
    """The criterion as users read it (see module docstring)."""
    return criterion_of(criterion).value(m, task)


def metrics(m: Array, rows: int, task: Array) -> dict[str, float]:
    """api.md's metrics and the observability indices O1-O5 of the stacked scaled Jacobian.

    O1 (Borm & Menq) = (σ₁⋯σₚ)^(1/P)/√m, O2 = σ_min/σ_max, O3 = σ_min, O4 (noise amplification,
    Nahvi & Hollerbach) = σ_min²/σ_max, O5 (Sun & Hollerbach) = 1/Σ(1/σᵢ); m = number of measured rows.
    """
    ev = np.clip(eigenvalues(m), 0.0, None)
    sigma = np.sqrt(ev)
    p = sigma.size
    singular = sigma[0] <= sigma[-1] * 1e-7
    inf = float("inf")
    log_det = float(np.sum(np.log(ev))) if not singular else -inf
    inv = np.linalg.inv(m) if not singular else None
    return {
        "condition_number": float(sigma[-1] / sigma[0]) if not singular else inf,
        "log_det": log_det,
        "min_singular_value": float(sigma[0]),
        "max_singular_value": float(sigma[-1]),
        "trace_inverse": float(np.trace(inv)) if inv is not None else inf,
        "predicted_rms_tcp_mm": float(np.sqrt(np.trace(task @ inv))) if inv is not None else inf,
        "O1": float(np.exp(np.mean(np.log(sigma))) / np.sqrt(rows)) if not singular else 0.0,
        "O2": float(sigma[0] / sigma[-1]),
        "O3": float(sigma[0]),
        "O4": float(sigma[0] ** 2 / sigma[-1]),
        "O5": float(1.0 / np.sum(1.0 / sigma)) if not singular else 0.0,
        "parameters": float(p),
    }
