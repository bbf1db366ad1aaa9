"""HTTP routes: parse, convert, call `operations` or `models`, shape the answer. Nothing else."""
