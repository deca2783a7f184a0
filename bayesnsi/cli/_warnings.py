"""bayesnsi warnings that reach the command line: one plain line each, as the errors are."""

from __future__ import annotations

import contextlib
import warnings

from .._text import printable
from ..exceptions import BayesNSIWarning

__all__ = ["plain_warnings"]


@contextlib.contextmanager
def plain_warnings():
    """Show a :class:`~bayesnsi.exceptions.BayesNSIWarning` not caught on the way as ``warning: ...``.

    Python's default shows the file, line and source line of the ``warnings.warn`` call, which
    says nothing to a user (e.g. a transient period in the estimation window, found while the data
    are loaded). Other warnings keep the default format.

    Yields
    ------
    None
    """
    previous = warnings.formatwarning

    def plain(message, category, filename, lineno, line=None):
        if issubclass(category, BayesNSIWarning):
            return f"warning: {printable(' '.join(str(message).split()), keep_newlines=False)}\n"
        return printable(previous(message, category, filename, lineno, line))  # e.g. a glyph named in a unit

    # the format, not warnings.showwarning: warnings.catch_warnings(record=True) (pytest.warns, callers
    # that collect the warnings) only keeps recording while showwarning is Python's own
    warnings.formatwarning = plain
    try:
        yield
    finally:
        warnings.formatwarning = previous


def periodic_hint(config, signals) -> str | None:
    """A note when the estimation force repeats but the config gives no ``[data] period``.

    A multisine test read without its period goes to the time route, which does not use the
    repetition (a simulated GVT file: every nonlinear candidate came out unstable there, and
    nothing said that the data were periodic).

    Parameters
    ----------
    config : ExperimentConfig
    signals : Signals
        Its estimation data.

    Returns
    -------
    str or None
        ``"note: the force repeats every N samples ..."`` (N at the file's rate), or None when the
        config gives a period or the force does not repeat (:func:`bayesnsi.nsi.steady.repeating_period`).
    """
    from ..nsi.steady import repeating_period

    if config.data.period is not None:
        return None
    lag = repeating_period(signals.force)
    if lag is None:
        return None
    period = lag * config.data.decimate
    return (
        f"note: the force repeats every {period} samples of the file: if the test is periodic in steady state, "
        f'[data] period = {period} and [nsi] domain = "frequency" use the repetition (docs/periodic.md)'
    )
