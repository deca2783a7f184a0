"""Tests of bayesnsi.loop: closing the loop, its screen, guards and acceptance rule."""
