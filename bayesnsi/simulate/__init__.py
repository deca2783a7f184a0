"""Reference simulators (SPEC section 8)."""
