"""The coefficient posteriors of a selection as netCDF files: ``DIR/posterior/<candidate>.nc``.

Each file is the arviz ``DataTree`` of :meth:`bayesnsi.evidence.PosteriorSamples.to_datatree`
(groups ``posterior``: ``coefficient`` (chain, draw, term), ``sigma``, ``rho``; ``sample_stats``:
``lp``), written by xarray with the h5netcdf engine (netCDF4/HDF5 with groups). Read one back
with :func:`read_posterior` or, in any notebook, ``xarray.open_datatree(path, engine="h5netcdf")``;
arviz functions take the tree as it is (e.g. ``arviz_stats.summary(tree)``,
``arviz_plots.plot_dist(tree)``).
"""

from __future__ import annotations

import re
from pathlib import Path

from ..exceptions import InputDataError
from .results import atomic_open

__all__ = ["POSTERIOR_DIRNAME", "NETCDF_ENGINE", "posterior_filename", "read_posterior", "write_posteriors"]

POSTERIOR_DIRNAME = "posterior"
"""Folder, inside the output folder, of the posterior files."""

NETCDF_ENGINE = "h5netcdf"
"""xarray engine of the posterior files (netCDF4 with groups; the scipy engine writes netCDF3, no groups)."""


def posterior_filename(name: str, taken=()) -> str:
    """A file name for a candidate's posterior: its name with anything but letters, digits, ``.-_`` as ``_``.

    Parameters
    ----------
    name : str
        Candidate name.
    taken : collection of str
        Names already used; a clash gets ``-2``, ``-3``, ...

    Returns
    -------
    str
        E.g. ``"quadratic_cubic.nc"`` for ``"quadratic + cubic"``.
    """
    stem = re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("._") or "candidate"
    stem = stem[:80]
    filename, k = f"{stem}.nc", 1
    while filename in taken:
        k += 1
        filename = f"{stem}-{k}.nc"
    return filename


def write_posteriors(folder, evidences, likelihood: str) -> dict[str, str]:
    """Write each candidate's posterior under ``likelihood`` to ``folder/posterior/<candidate>.nc``.

    Parameters
    ----------
    folder : str or path-like
        The output folder.
    evidences : mapping of str to mapping of str to EvidenceResult
        ``Selection.evidences``: candidate -> likelihood -> evidence.
    likelihood : str
        Which likelihood's draws to write (the one that selects).

    Returns
    -------
    dict of str to str
        Candidate name -> file path relative to ``folder`` (candidates without an evidence are left out).

    Notes
    -----
    Each file is built in memory first, then written by :func:`bayesnsi.io.results.atomic_open`
    (the folder is created there; inside a locked output folder a ``posterior`` that is a link or
    a file is refused, and a file bayesnsi did not write is replaced only with ``--force``).
    """
    target = Path(folder) / POSTERIOR_DIRNAME
    written: dict[str, str] = {}
    for name, by_likelihood in evidences.items():
        evidence = (by_likelihood or {}).get(likelihood)
        if evidence is None:
            continue
        filename = posterior_filename(name, {Path(p).name for p in written.values()})
        tree = evidence.posterior.to_datatree()
        tree.attrs.update(
            candidate=name, likelihood=likelihood, log_evidence=float(evidence.log_evidence),
            log_evidence_se=float(evidence.log_evidence_se), written_by=_written_by(),
        )
        if not target.is_symlink():
            target.mkdir(exist_ok=True)
        data = tree.to_netcdf(engine=NETCDF_ENGINE)  # in memory: HDF5 never writes to disk (no crash on a full one)
        with atomic_open(target / filename, "wb") as fh:  # a complete file or none, never through a link
            fh.write(data)
        written[name] = f"{POSTERIOR_DIRNAME}/{filename}"
    return written


def read_posterior(path):
    """Read a posterior file written by :func:`write_posteriors` into an arviz ``DataTree``.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    xarray.DataTree
        Loaded into memory (the file is closed).

    Raises
    ------
    InputDataError
        When the file is missing.
    """
    import xarray as xr

    path = Path(path)
    if not path.is_file():
        raise InputDataError(f"posterior file {path} not found")
    with xr.open_datatree(path, engine=NETCDF_ENGINE) as tree:
        return tree.load()


def _written_by() -> str:
    from .._version import __version__

    return f"bayesnsi {__version__}"
