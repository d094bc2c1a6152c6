"""The mission tree's own decorators (py_trees' decorators are used as they are)."""
