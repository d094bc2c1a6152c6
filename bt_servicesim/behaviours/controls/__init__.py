"""The mission tree's own control nodes, beside py_trees' Sequence, Fallback and Parallel."""
