"""Compensation: joint commands that put the calibrated robot's TCP exactly on target."""

from models.compensation.compensate import Compensation, correct_program, default_seed, inverse_kinematics

__all__ = ["Compensation", "correct_program", "default_seed", "inverse_kinematics"]
