"""Small experiments on disk (CSV + config) for the command-line tests, and how their processes start."""

import signal

import numpy as np

# A two-DOF record (``bayesnsi simulate two-dof``, as ``two_dof.csv``) with one candidate and a short MCMC.
SELECT_CONFIG = (
    '[data]\nfile = "two_dof.csv"\nfs = 100.0\ninputs = { f2 = 2 }\noutputs = { x1 = 1, x2 = 2 }\n'
    "[nsi]\nblock_rows = 40\norder = 4\n"
    '[evidence]\nn_steps = 400\nn_burn = 100\nlikelihood = "white"\ncompare = []\ninterval = "posterior"\n'
    '[[candidates]]\nname = "model 1"\nterms = [{ expr = "x1**3", at = 1 }]\n'
)

# Candidates appended to the config ``bayesnsi simulate two-dof`` writes: the paper's 3 + 3 more, short MCMC.
EXTRA_CANDIDATES = """
[[candidates]]
name = "linear"
terms = []

[[candidates]]
name = "cubic 1"
terms = [{ expr = "x1**3", at = 1 }]

[[candidates]]
name = "quadratic damping 2"
terms = [{ expr = "v2*abs(v2)", at = 2 }]

[evidence]
n_steps = 400
n_burn = 100
compare = []
"""


def experiment_config(folder, edit=None, csv_columns=None):
    """A small valid experiment (CSV + config) in ``folder``, optionally edited; returns the config path."""
    from bayesnsi.io import dump_config

    n = 300
    rng = np.random.default_rng(1)
    columns = csv_columns or {"f2": rng.normal(size=n), "x1": rng.normal(size=n), "x2": rng.normal(size=n)}
    lines = [",".join(["t", *columns])]
    lines += [",".join([repr(k / 100.0)] + [repr(float(v[k])) for v in columns.values()]) for k in range(n)]
    (folder / "data.csv").write_text("\n".join(lines) + "\n")
    raw = {
        "data": {"file": "data.csv", "fs": 100.0, "inputs": {"f2": 2}, "outputs": {"x1": 1, "x2": 2}},
        "nsi": {"block_rows": 10, "order": 4},
        "candidates": [{"name": "cubic", "terms": [{"expr": "x1**3", "at": 1}]}],
    }
    if edit is not None:
        edit(raw)
    path = folder / "experiment.toml"
    path.write_text(dump_config(raw))
    return path


def default_signals() -> None:
    """``preexec_fn`` of a command the tests signal: SIGINT and SIGTERM at their default disposition.

    A job started in the background by a shell (``make test &``) inherits an ignored SIGINT, which
    Python keeps ignored; a terminal's foreground job, which these tests stand for, has the default.
    """
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, signal.SIG_DFL)
