"""Compensation: joint commands that put the calibrated robot's TCP exactly on target."""

from models.compensation.compensate import Compensation, compensate, correct_program
from models.inverse import default_seed, inverse_kinematics

__all__ = ["Compensation", "compensate", "correct_program", "default_seed", "inverse_kinematics"]
