"""help() of the main entry points is short and has the sections a user looks for."""

from __future__ import annotations

import pydoc

import bayesnsi.nsi


def test_help_of_identify_is_short_with_parameters_returns_references_and_an_example():
    text = pydoc.render_doc(bayesnsi.nsi.identify, renderer=pydoc.plaintext)
    assert len(text) < 4000, len(text)  # it ran to 8 000 characters
    for section in ("Parameters", "Returns", "References", "Examples", "See Also"):
        assert f"\n    {section}\n" in text, section
    assert "Notes" not in text  # the long notes live in docs/method.md
    assert "SPEC" not in text
