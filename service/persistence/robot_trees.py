"""Robots of several chains and their calibrations, stored; every method works inside the caller's transaction.

A tree's changes (created, calibrated, deleted) go to the audit trail beside the robots' (`robot_id` there is the
tree's id) and bump its revision, its ETag, in the same transaction."""

from __future__ import annotations

from typing import Any

from sqlalchemy import select

from service.audit_actions import AuditAction
from service.persistence.lifecycle import Actor, check_if_match
from service.persistence.repository import new_id
from service.persistence.store import Store
from service.persistence.tables import AuditEvent, RobotTreeCalibrationRecord, RobotTreeRecord


def tree_etag(tree: RobotTreeRecord) -> str:
    return f'"{tree.revision}"'


def check_tree_revision(tree: RobotTreeRecord, if_match: str | None) -> None:
    """If-Match against the tree's revision, as a robot's (`lifecycle.check_if_match`)."""
    check_if_match(if_match, tree_etag(tree), f"robot tree {tree.id!r}")


class TreeStore(Store):
    def add_tree(
        self, *, name: str, document: dict[str, Any], source: str, actor: Actor, **urdf: Any
    ) -> RobotTreeRecord:
        row = self._insert(
            RobotTreeRecord(
                id=new_id(), name=name, document=document, source=source, revision=1, actor=actor.name, **urdf
            )
        )
        self._audit(row, AuditAction.TREE_CREATED, actor, {"name": name})
        return row

    def tree(self, tree_id: str, *, lock: bool = False) -> RobotTreeRecord:
        tree: RobotTreeRecord = self._selected_by_id(RobotTreeRecord, tree_id, "robot_tree", lock=lock)
        return tree

    def trees(self, limit: int, offset: int) -> list[RobotTreeRecord]:
        query = select(RobotTreeRecord).order_by(RobotTreeRecord.created_at, RobotTreeRecord.id)
        return list(self.s.scalars(query.limit(limit).offset(offset)))

    def delete_tree(self, tree: RobotTreeRecord, actor: Actor) -> None:
        self._audit(tree, AuditAction.TREE_DELETED, actor, {"name": tree.name})
        self.s.delete(tree)
        self.s.flush()

    def add_calibration(self, row: RobotTreeCalibrationRecord) -> RobotTreeCalibrationRecord:
        return self._insert(row)

    def apply(
        self, tree: RobotTreeRecord, calibration_id: str, values: list[float], std_errors: list[Any], actor: Actor
    ) -> int:
        """The calibration's parameters become the tree's: a new revision, audited."""
        tree.parameters, tree.std_errors, tree.calibration_id = list(values), list(std_errors), calibration_id
        tree.revision = tree.revision + 1
        self._audit(tree, AuditAction.TREE_CALIBRATED, actor, {"calibration_id": calibration_id})
        return tree.revision

    def calibrations(self, tree_id: str, limit: int, offset: int) -> list[RobotTreeCalibrationRecord]:
        table = RobotTreeCalibrationRecord
        query = select(table).where(table.tree_id == tree_id).order_by(table.created_at, table.id)
        return list(self.s.scalars(query.limit(limit).offset(offset)))

    def calibration(self, calibration_id: str) -> RobotTreeCalibrationRecord:
        return self._by_id(RobotTreeCalibrationRecord, calibration_id, "robot_tree_calibration")

    def _audit(self, tree: RobotTreeRecord, action: AuditAction, actor: Actor, details: dict[str, Any]) -> None:
        self._insert(
            AuditEvent(
                actor=actor.name,
                request_id=actor.request_id,
                action=AuditAction(action).value,
                robot_id=tree.id,
                version=tree.revision,
                details=details,
            )
        )
