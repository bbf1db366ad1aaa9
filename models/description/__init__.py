"""What a robot is: the frozen `RobotDescription` (base, stages, tool), its parts' mathematics, its parameters
and model terms, the robots.md document read and written, and the example robots.
"""
