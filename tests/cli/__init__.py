"""Tests of bayesnsi.cli: the commands, their exit codes and what they print."""
