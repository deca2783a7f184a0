"""Is a model good enough? Model checks beside the evidence, each returning typed findings.

The posterior probabilities rank the candidates against each other; these checks say whether a
model explains the data at all, and where it does not:

- :mod:`~bayesnsi.checks.adequacy`: the residual against the noise the model passes on, the quality
  index, negative dissipation, validation error and predictive density (:class:`ModelCheck`);
- :mod:`~bayesnsi.checks.residual_bands`: the same ratio band by band;
- :mod:`~bayesnsi.checks.validation`: closed-loop errors on held-out data, residual whiteness,
  errors in the measured quantity;
- :mod:`~bayesnsi.checks.dissipation`: friction or damping terms that feed energy in;
- :mod:`~bayesnsi.checks.force_noise`, :mod:`~bayesnsi.checks.velocity_noise`: data the model
  cannot be held to (noise on the measured force, velocities differentiated from noisy displacements);
- :mod:`~bayesnsi.checks.free_view`: one view per record for free bodies.

Every check reports :class:`~bayesnsi.findings.Finding` records; warnings, the terminal, the report
and results.json render those same records.
"""

from .adequacy import VALIDATION_TOLERANCE, ModelCheck, adequacy_findings, model_checks, unsupported_terms
from .dissipation import dissipative_shape, injects_energy
from .force_noise import FORCE_NOISE_SHARE, force_noise_findings
from .free_view import free_body_view, view_findings
from .residual_bands import MAX_BAND_RATIO, ResidualBands, band_findings, propagated_noise, residual_bands
from .validation import (
    ADEQUACY_LEVEL,
    LEVEL_MISMATCH,
    VALIDATION_INIT_SAMPLES,
    SegmentError,
    Whiteness,
    level_findings,
    measured_errors,
    open_loop_error,
    residual_whiteness,
    validate,
    whiteness_applies,
    whiteness_test,
)
from .velocity_noise import VELOCITY_NOISE_LIMIT, velocity_noise_findings

__all__ = [
    "ADEQUACY_LEVEL",
    "FORCE_NOISE_SHARE",
    "LEVEL_MISMATCH",
    "MAX_BAND_RATIO",
    "VALIDATION_INIT_SAMPLES",
    "VALIDATION_TOLERANCE",
    "VELOCITY_NOISE_LIMIT",
    "ModelCheck",
    "ResidualBands",
    "SegmentError",
    "Whiteness",
    "adequacy_findings",
    "band_findings",
    "dissipative_shape",
    "force_noise_findings",
    "free_body_view",
    "injects_energy",
    "level_findings",
    "measured_errors",
    "model_checks",
    "open_loop_error",
    "propagated_noise",
    "residual_bands",
    "residual_whiteness",
    "unsupported_terms",
    "validate",
    "velocity_noise_findings",
    "view_findings",
    "whiteness_applies",
    "whiteness_test",
]
