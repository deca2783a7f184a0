"""File input/output: the only layer that touches files."""
