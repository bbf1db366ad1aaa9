"""Where work runs and what it may cost: the compute processes and the parse process, where a body's computation
runs, bounded work, a process's runtimes and model cache, background builds, the parent watch and crash points.
"""
