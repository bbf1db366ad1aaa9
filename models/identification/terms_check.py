"""After a fit that fails its variance-factor test: does a missing temperature or load term explain it?

A score (Lagrange-multiplier) test at the geometric solution, in closed form from its own Jacobian: the columns a
term would add are known without building the term's graphs. A leg's thermal column is `ΔT (l_k + δl_k)` times
the column of its offset (the closure holds `|v_k| = (l_k + δl_k)(1 + κ ΔT)`, and an offset enters it as the
length does); a prismatic axis's is `ΔT q_j` times the column of its `d`; a leg's compliance column is its
tension `t_k` (hexapod statics, `models.description.terms`) times its offset's column. Projected off the fitted columns,
the squared residual along them is χ²(k) if the term is absent; far above, the residuals follow the
temperature (load). A serial robot's joint compliance column is its gravity torque times its θ's column.
"""

from __future__ import annotations

import numpy as np

from models._types import Array
from models.description.robot import RobotDescription
from models.description.serial_chain import JointType
from models.description.terms import GRAVITY_M_S2, MIN_PAYLOAD_SPREAD_KG, Conditions
from models.identification.diagnosis import Diagnosis, Finding
from models.identification.residuals import CampaignProblem, Evaluation
from models.identification.statistics import chi2_quantile
from models.kinematics import leg_tensions

SCORE_ALPHA = 1e-4
"""The score test names a missing term only beyond this false-alarm probability."""


def missing_term_diagnoses(problem: CampaignProblem, ev: Evaluation) -> tuple[Diagnosis, ...]:
    """The findings for the terms `problem`'s description lacks and its records' conditions could show."""
    desc, conditions = problem.desc, problem.campaign.conditions
    if conditions is None:
        return ()
    active = problem.active_poses
    found: list[Diagnosis] = []
    temps = conditions.temperature_c
    if not desc.terms.thermal and temps is not None and np.ptp(temps[active]) > 0 and thermal_axes(desc):
        columns = _thermal_columns(problem, ev, temps[active] - desc.terms.reference_temperature_c)
        stat, k, limit = _score(problem, ev, columns)
        if stat > limit:
            span = float(np.ptp(temps[active]))
            found.append(
                Diagnosis(
                    Finding.TEMPERATURE_TERM,
                    f"the residuals follow the records' temperatures (score test {stat:.1f} on {k} degrees of "
                    f"freedom, limit {limit:.1f}; the campaign spans {span:.1f} K): a temperature term may be "
                    'missing; calibrate with options.terms ["thermal"]',
                    blocking=False,
                )
            )
    mass = conditions.payload_kg
    loadable = desc.hexapod is not None or bool(desc.revolute_joints)
    if not desc.terms.compliance and loadable and mass is not None and np.ptp(mass[active]) >= MIN_PAYLOAD_SPREAD_KG:
        columns = _compliance_columns(problem, ev) if desc.hexapod is not None else _joint_columns(problem, ev)
        stat, k, limit = _score(problem, ev, columns)
        if stat > limit:
            found.append(
                Diagnosis(
                    Finding.LOAD_TERM,
                    f"the residuals follow the records' payloads (score test {stat:.1f} on {k} degrees of freedom, "
                    f"limit {limit:.1f}): a load (compliance) term may be missing; calibrate with options.terms "
                    '["compliance"]',
                    blocking=False,
                )
            )
    return tuple(found)


def thermal_axes(desc: RobotDescription) -> bool:
    """Whether the thermal term has anything to expand in `desc`: hexapod legs or prismatic axes. A revolute arm
    has neither (its thermal growth is not modelled), so its records' temperatures cannot enter the model: the
    score test then had no column at all (a 6R arm's Leica file with a Temperature column crashed here, issue 45)."""
    return desc.hexapod is not None or any(link.joint is JointType.PRISMATIC for link in desc.links)


def unused_temperature_note(desc: RobotDescription, conditions: Conditions | None) -> str | None:
    """The note for records that carry temperatures this robot's model cannot use (None when it can, or when
    they carry none)."""
    if conditions is None or conditions.temperature_c is None or thermal_axes(desc):
        return None
    return (
        f"temperature_c read (the records span {conditions.temperature_span_k:.2g} K) but unused: the thermal term "
        "expands hexapod legs and prismatic axes, and this robot has neither"
    )


def _score(problem: CampaignProblem, ev: Evaluation, columns: list[Array]) -> tuple[float, int, float]:
    """(statistic, degrees of freedom, limit) of the score test of the weighted columns (N, rows) each."""
    rows = problem.rows
    w = problem.weights[problem.active_poses]
    a = np.stack([(c[:, :rows] * w).reshape(-1) for c in columns], axis=1)
    q, _ = np.linalg.qr(ev.jacobian)
    a_perp = a - q @ (q.T @ a)
    u, s, _ = np.linalg.svd(a_perp, full_matrices=False)
    keep = s > 1e-9 * max(float(s.max(initial=0.0)), 1e-300)
    k = int(keep.sum())
    if k == 0:
        return 0.0, 0, float("inf")
    r = ev.residuals.reshape(-1)
    stat = float(np.sum((u[:, keep].T @ r) ** 2))
    # The variance factor stays 1 in the null hypothesis: the test is on the stated noise, as the χ² test is.
    return stat, k, chi2_quantile(1 - SCORE_ALPHA, k)


def _offset_index(problem: CampaignProblem, leg: int) -> int:
    return problem.desc.parameters.index[f"leg{leg + 1}.offset"]


def _thermal_columns(problem: CampaignProblem, ev: Evaluation, dt: Array) -> list[Array]:
    desc = problem.desc
    q = problem.campaign.joints[problem.active_poses]
    jac = ev.raw_jacobian  # (N, rows, P)
    out: list[Array] = []
    if desc.hexapod is not None:
        legs = q[:, desc.n_chain :]
        offsets = ev.theta[[_offset_index(problem, k) for k in range(6)]]
        col = sum((dt * (legs[:, k] + offsets[k]))[:, None] * jac[:, :, _offset_index(problem, k)] for k in range(6))
        out.append(np.asarray(col))
    axes = np.zeros_like(jac[:, :, 0])
    k = 0
    start = desc.slices["carriage"].start
    for i, link in enumerate(desc.links):
        if link.joint is JointType.PRISMATIC:
            d_index = start + desc.link_param_offsets[i] + 1  # theta, d, a, alpha: d is the second
            axes += (dt * q[:, k])[:, None] * jac[:, :, d_index]
        k += link.joint.moves
    if np.any(axes):
        out.append(axes)
    return out


def _joint_columns(problem: CampaignProblem, ev: Evaluation) -> list[Array]:
    """A serial robot's: per revolute joint, its gravity torque τ_j = F · ∂p_cog/∂q_j (virtual work, from the
    TCP's joint Jacobian) times the column of its θ (a revolute joint's reading adds to θ)."""
    desc, campaign = problem.desc, problem.campaign
    assert campaign.conditions is not None
    active = problem.active_poses
    mass, cog = campaign.conditions.payload_kg, campaign.conditions.payload_cog_mm
    assert mass is not None and cog is not None
    q = campaign.joints[active]
    _, rot, jq = problem.runtime.kinematics.batch("joint_jacobian_at", q, ev.theta, ev.platforms)
    force = (mass[active] * GRAVITY_M_S2)[:, None] * desc.terms.gravity_unit()[None, :]
    arm = np.einsum("nij,nj->ni", rot, cog[active])  # the cog relative to the TCP, world frame
    start = desc.slices["carriage"].start
    out: list[Array] = []
    k = 0
    for i, link in enumerate(desc.links):
        if not link.joint.moves:
            continue
        if link.joint is JointType.REVOLUTE:
            velocity = jq[:, :3, k] + np.cross(jq[:, 3:, k], arm)  # of the cog per unit q_k
            torque = np.einsum("ni,ni->n", force, velocity) / 1000.0
            theta_index = start + desc.link_param_offsets[i]
            out.append(torque[:, None] * ev.raw_jacobian[:, :, theta_index])
        k += 1
    return out


def _compliance_columns(problem: CampaignProblem, ev: Evaluation) -> list[Array]:
    """Per leg: its tension under the record's payload times its offset's column."""
    desc, campaign = problem.desc, problem.campaign
    assert desc.hexapod is not None and campaign.conditions is not None
    active = problem.active_poses
    mass = campaign.conditions.payload_kg
    cog = campaign.conditions.payload_cog_mm
    assert mass is not None and cog is not None
    force_w = (mass[active] * GRAVITY_M_S2)[:, None] * desc.terms.gravity_unit()[None, :]
    q = campaign.joints[active]
    tension = leg_tensions(
        desc, q, ev.theta, ev.platforms, force_world=force_w, cog_mm=cog[active], runtime=problem.runtime
    )
    jac = ev.raw_jacobian
    return [tension[:, k][:, None] * jac[:, :, _offset_index(problem, k)] for k in range(6)]
