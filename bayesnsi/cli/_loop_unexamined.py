"""Effects the loop re-identified but never examined, that might have been added (``n_tries``).

The loop examines, per step, only the ``n_tries`` effects best by evidence among those it
re-identified. When those all fail a guard it ends with nothing added, although an effect ranked
below them may pass the quality index and the Bayes factor (trial of a GVT file: the joint's
``(x7-x8)**3``, log Bayes factor 3.6e4 and |Im|/|Re| 0.20, ranked 4th behind three effects that
failed; with ``n_tries = 6`` the loop added it first). "Nothing added" must then not read as
"nothing passes": the note names them and the setting that examines them.
"""

from __future__ import annotations

__all__ = ["unexamined_note"]


def unexamined_note(payload) -> str:
    """A sentence naming the effects not examined that pass the Bayes factor and the quality index.

    Parameters
    ----------
    payload : dict
        The ``bayesnsi diagnose`` results.json payload: ``loop_scores`` (per search, each effect's
        ``status``, ``log_bayes_factor``, ``imag_ratio``) and ``settings["loop"]`` (``threshold``,
        ``max_imag_ratio``, ``n_tries``).

    Returns
    -------
    str
        With a leading space, e.g. `` Not examined: (x7-x8)**3@7-8 (log Bayes factor 3.6e+04,
        |Im|/|Re| 0.2) - ...``; "" when there is none.
    """
    settings = payload.get("settings", {}).get("loop", {})
    threshold = settings.get("threshold", 0.0)
    limit = settings.get("max_imag_ratio", 0.3)
    n_tries = settings.get("n_tries")
    seen: dict[str, tuple[float, float]] = {}
    for search in payload.get("loop_scores") or ():
        for record in search:
            bf, ratio = record.get("log_bayes_factor"), record.get("imag_ratio")
            if record.get("status") != "not checked" or bf is None or ratio is None:
                continue
            if bf > threshold and ratio <= limit and record.get("term") not in seen:
                seen[record["term"]] = (bf, ratio)
    if not seen or not n_tries:
        return ""
    names = ", ".join(f"{term} (log Bayes factor {bf:.3g}, |Im|/|Re| {ratio:.2g})"
                      for term, (bf, ratio) in seen.items())
    return (
        f" Not examined: {names} - it passes the Bayes factor and the quality index, but each step examines only the "
        f"n_tries = {n_tries} effects best by evidence; rerun with --n-tries {n_tries + len(seen) + 2} (or "
        "[diagnose] n_tries) to examine it."
    )
