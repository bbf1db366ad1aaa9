"""The audit trail's actions, defined once: persistence writes them, the schema publishes and filters by them."""

from __future__ import annotations

from enum import StrEnum


class AuditAction(StrEnum):
    """The robot's own changes, then every way its current parameter version changes, then its cell's, then a
    robot tree's (its id in the event's `robot_id`, its revision in `version`; the contract's order)."""

    ROBOT_CREATED = "robot.created"
    ROBOT_UPDATED = "robot.updated"
    ROBOT_DELETED = "robot.deleted"
    VERSION_CALIBRATED = "version.calibrated"
    VERSION_RESTORED = "version.restored"
    VERSION_IMPORTED = "version.imported"
    VERSION_EDITED = "version.edited"
    CELL_UPDATED = "cell.updated"
    CELL_ENDED = "cell.ended"
    TREE_CREATED = "tree.created"
    TREE_CALIBRATED = "tree.calibrated"
    TREE_DELETED = "tree.deleted"
