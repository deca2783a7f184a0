"""Identification (SPEC sections 2-5)."""
