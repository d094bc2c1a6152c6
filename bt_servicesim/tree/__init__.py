"""A mission tree as an object: loading its file, its node model, its shape, ticking it."""
