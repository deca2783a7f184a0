"""bayesnsi warnings that reach the command line: one plain line each, as the errors are."""

from __future__ import annotations

import contextlib
import sys
import warnings

from ..exceptions import BayesNSIWarning

__all__ = ["plain_warnings"]


@contextlib.contextmanager
def plain_warnings():
    """Print a :class:`~bayesnsi.exceptions.BayesNSIWarning` not caught on the way as ``warning: ...``.

    Python's default shows the file, line and source line of the ``warnings.warn`` call, which
    says nothing to a user (e.g. a transient period in the estimation window, found while the data
    are loaded). Other warnings keep the default format.

    Yields
    ------
    None
    """
    previous = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, BayesNSIWarning):
            print(f"warning: {' '.join(str(message).split())}", file=sys.stderr if file is None else file)
        else:
            previous(message, category, filename, lineno, file, line)

    warnings.showwarning = show
    try:
        yield
    finally:
        warnings.showwarning = previous
