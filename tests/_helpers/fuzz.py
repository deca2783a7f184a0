"""What the property-based fuzzing of the readers and of the command line share.

A scratch folder holding a valid CSV record, the sane config around it, the strategy of scalar
values, the number of examples of the long-running properties and the judge of one outcome: a
value or a BayesNSIError, with any BayesNSIWarning; another exception or warning fails.
"""

import os
import tempfile
import warnings
from pathlib import Path

import numpy as np
from hypothesis import event
from hypothesis import strategies as st

from bayesnsi.exceptions import BayesNSIError, BayesNSIWarning

FOLDER = Path(tempfile.mkdtemp(prefix="bayesnsi-fuzz-"))
N_ROWS = 120

# 60 examples by default, 10 000 under BAYESNSI_HYPOTHESIS_PROFILE=long
CACHE_EXAMPLES = 10_000 if os.environ.get("BAYESNSI_HYPOTHESIS_PROFILE") == "long" else 60

SANE = {
    "data": {"file": "data.csv", "fs": 100.0, "inputs": {"f2": 2}, "outputs": {"x1": 1, "x2": 2}},
    "candidates": [{"name": "m", "terms": [{"expr": "x1**3", "at": 1}]}],
}

scalars = (
    st.integers(-5, 300) | st.integers(-(2**63), 2**63 - 1) | st.floats(allow_nan=True, allow_infinity=True)
    | st.booleans() | st.text(max_size=8) | st.sampled_from(["auto", "ar1", "white", "robust", "fourth", "time"])
)


def _write_valid_csv(path: Path) -> None:
    rng = np.random.default_rng(0)
    names = ["t", "f2", "x1", "x2", "v1", "v2", "a1"]
    rows = [",".join(names)]
    for k in range(N_ROWS):
        rows.append(",".join([repr(k / 100.0)] + [repr(float(v)) for v in rng.normal(size=len(names) - 1)]))
    path.write_text("\n".join(rows) + "\n")


_write_valid_csv(FOLDER / "data.csv")


def outcome(call):
    """Run ``call``; a BayesNSIError is a valid outcome, anything else fails the test."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BayesNSIWarning)  # its warnings are results too; only exceptions are judged
        try:
            result = call()
        except BayesNSIError as err:
            assert str(err).strip(), "an error needs a message"
            event(f"error: {type(err).__name__}")
            return err
    event(f"result: {type(result).__name__}")
    return result


def patched(patch):
    """The sane config with some sections replaced or, where both are tables, updated."""
    document = {key: (dict(value) if isinstance(value, dict) else value) for key, value in SANE.items()}
    for key, value in patch.items():
        if isinstance(value, dict) and isinstance(document.get(key), dict):
            document[key].update(value)
        else:
            document[key] = value
    return document
