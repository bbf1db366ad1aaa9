"""A model in and out of other tools' files: URDF (import, export, the calibrated drop-in), joint-to-joint chains,
UR's calibration YAML and DH tables. Each reads or writes a `RobotDescription` and its parameters.
"""
