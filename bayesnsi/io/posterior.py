"""The posteriors of a run as netCDF files: ``DIR/posterior/<model>.nc`` (layout: docs/posterior-files.md).

Each file is an arviz ``DataTree`` written by xarray with the h5netcdf engine (netCDF4/HDF5 with
groups), built by :func:`posterior_tree`:

* ``posterior``: ``coefficient`` (chain, draw, term) - draws that carry the honest intervals of
  results.json (:func:`bayesnsi.uncertainty.draws.interval_draws`: the linear part's uncertainty
  included), so ``arviz_stats.summary(tree, ci_prob=0.95)`` gives them; ``frequency`` and
  ``damping_ratio`` (chain, draw, mode) the same for the modes (their draws independent across modes);
* ``posterior_given_linear_part``: the sampler's draws, ``coefficient``, ``sigma`` (chain, draw,
  channel) and, for AR likelihoods, ``rho``: the posterior that takes the identified linear part as
  exact (too narrow as an uncertainty of the coefficients);
* ``sample_stats``: ``lp`` of the sampler's draws;
* ``log_likelihood``: ``response`` (chain, draw, block), the log-likelihood of each contiguous block
  of the record at the sampler's draws (:mod:`bayesnsi.evidence.pointwise`), so that
  ``arviz_stats.loo(tree)`` and ``arviz_stats.compare`` give leave-one-block-out estimates.

Variables carry ``units`` and ``description`` attributes; the tree's attributes name the model, the
likelihood, the log evidence and its Monte-Carlo error, the sampler and the interval method. Read one
back with :func:`read_posterior` or ``xarray.open_datatree(path, engine="h5netcdf")``.
"""

from __future__ import annotations

import re
from pathlib import Path

from ..exceptions import InputDataError
from .results import atomic_open

__all__ = ["POSTERIOR_DIRNAME", "NETCDF_ENGINE", "posterior_filename", "posterior_tree", "read_posterior",
           "write_posteriors"]

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


def posterior_tree(name: str, evidence, intervals=None, units=None):
    """The ``DataTree`` of one model's posterior file (module notes).

    Parameters
    ----------
    name : str
        The model's name.
    evidence : EvidenceResult
        Its evidence (the sampler's draws).
    intervals : Intervals, optional
        Its honest intervals; without them ``posterior`` holds the sampler's draws (and says so).
    units : ChannelUnits, optional
        Units of the data, for the variables' ``units`` attributes.

    Returns
    -------
    xarray.DataTree
    """
    import numpy as np
    import xarray as xr

    from ..uncertainty.draws import interval_draws
    from .units import ChannelUnits, term_unit

    units = units or ChannelUnits()
    given = evidence.posterior.to_datatree()
    sampled = given["posterior"].to_dataset()
    term_units = [term_unit(t.rsplit("@", 1)[0], units) for t in evidence.coefficient_names]
    honest = intervals is not None and intervals.method != "posterior"
    posterior = {}
    if "coefficient" in sampled:
        values = sampled["coefficient"].values
        if honest and len(intervals.coefficients) == values.shape[-1]:
            values = interval_draws(intervals.coefficients, values)
        posterior["coefficient"] = xr.DataArray(values, dims=("chain", "draw", "term"), attrs={
            "units": term_units, "description": "coefficient λ of each term" + (
                f"; draws with the honest intervals ({intervals.method} + posterior: the linear part's uncertainty "
                "included)" if honest else "; the posterior given the identified linear part")})
    if honest and intervals.frequencies:
        chains, draws = sampled.sizes["chain"], sampled.sizes["draw"]
        normal = np.random.default_rng(0).standard_normal((chains, draws, len(intervals.frequencies)))
        posterior["frequency"] = xr.DataArray(interval_draws(intervals.frequencies, normal),
                                              dims=("chain", "draw", "mode"), attrs={
                "units": "Hz", "description": "natural frequency of each mode (honest interval; modes independent)"})
        posterior["damping_ratio"] = xr.DataArray(interval_draws(intervals.damping_ratios, normal),
                                                  dims=("chain", "draw", "mode"), attrs={
                "units": "1", "description": "damping ratio of each mode (honest interval; modes independent)"})
    coords = {"chain": sampled["chain"].values, "draw": sampled["draw"].values}
    if "term" in sampled.coords:
        coords["term"] = sampled["term"].values
    if "frequency" in posterior:
        coords["mode"] = np.arange(1, len(intervals.frequencies) + 1)
    sampler = evidence.sampler.describe() if getattr(evidence, "sampler", None) is not None else str(
        sampled.attrs.get("sampler", "emcee"))
    drawn = {**sampled.attrs, "sampler": sampler, "draws": "honest intervals" if honest else "the sampler's"}
    groups = {"posterior": xr.Dataset(posterior, coords=coords, attrs=drawn),
              "posterior_given_linear_part": sampled, "sample_stats": given["sample_stats"].to_dataset()}
    pointwise = evidence.pointwise_log_likelihood() if hasattr(evidence, "pointwise_log_likelihood") else None
    if pointwise is not None:  # the draws of posterior_given_linear_part, block by block (arviz_stats.loo)
        bounds = evidence.blocks.bounds
        groups["log_likelihood"] = xr.Dataset(
            {"response": xr.DataArray(pointwise, dims=("chain", "draw", "block"), attrs={
                "units": "nat", "block_start": [int(b) for b in bounds[:, 0]],
                "block_stop": [int(b) for b in bounds[:, 1]],
                "description": f"log-likelihood ({evidence.likelihood}) of each contiguous block of the record "
                "(samples block_start..block_stop-1) at the draws of posterior_given_linear_part"})},
            coords={"chain": sampled["chain"].values, "draw": sampled["draw"].values,
                    "block": np.arange(pointwise.shape[-1])})
    if "coefficient" in sampled:
        sampled["coefficient"].attrs.update(units=term_units, description="coefficient λ given the linear part")
    sampled["sigma"].attrs.update(units=units.displacement or "data units",
                                  description="noise std of each output channel")
    if "rho" in sampled:
        sampled["rho"].attrs.update(units="1", description="AR coefficient of each output channel's residual")
    tree = xr.DataTree.from_dict(groups)
    tree.attrs.update(
        model=name, likelihood=evidence.likelihood, log_evidence=float(evidence.log_evidence),
        log_evidence_se=float(evidence.log_evidence_se), interval=intervals.method if intervals is not None else "none",
        sampler=sampler, written_by=_written_by(),
    )
    return tree


def write_posteriors(folder, evidences, intervals=None, units=None) -> dict[str, str]:
    """Write each model's posterior to ``folder/posterior/<name>.nc``.

    Parameters
    ----------
    folder : str or path-like
        The output folder.
    evidences : mapping of str to EvidenceResult
        Model name -> its evidence under the primary likelihood.
    intervals : mapping of str to Intervals, optional
        Model name -> its honest intervals.
    units : ChannelUnits, optional
        Units of the data.

    Returns
    -------
    dict of str to str
        Model name -> file path relative to ``folder`` (models without an evidence are left out).

    Notes
    -----
    Each file is built in memory first, then written by :func:`bayesnsi.io.results.atomic_open`
    (the folder is created there; inside a locked output folder a ``posterior`` that is a link or
    a file is refused, and a file bayesnsi did not write is replaced only with ``--force``).
    """
    target = Path(folder) / POSTERIOR_DIRNAME
    written: dict[str, str] = {}
    for name, evidence in evidences.items():
        if evidence is None:
            continue
        filename = posterior_filename(name, {Path(p).name for p in written.values()})
        tree = posterior_tree(name, evidence, (intervals or {}).get(name), units)
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
