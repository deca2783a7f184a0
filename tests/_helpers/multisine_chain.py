"""The two-DOF chain with a cubic spring at DOF 1 (k3 = 1e5 N/m³) driven at DOF 2 by a periodic multisine.

The record of the frequency-route tests (docs/method.md §11): 10 periods of 1000 samples at 100 Hz
in steady state, 2 % output noise, simulated by RK4 on a fine grid (bayesnsi.simulate).
"""

import numpy as np

from bayesnsi.models import Term
from bayesnsi.signals import Signals
from bayesnsi.simulate import add_output_noise, chain_system, multisine, simulate_response

FS, P, N_PERIODS, TRANSIENT = 100.0, 1000, 10, 4
K3 = 1e5
MCK = chain_system([1.0, 1.5], [800.0, 1000.0], [2.0, 2.0])
CUBIC = [Term("x1**3", 1)]


def periodic_record(seed: int = 0, rms: float = 5.0, noise: float = 2.0, k3: float = K3, kind: str = "full") -> Signals:
    """10 periods of a random-phase multisine (0.5-20 Hz) in steady state; 2 % output noise.

    The slowest mode decays as e^{-0.28 t}: one 10 s period leaves 6 % of the start transient, so
    four leading periods are simulated and dropped.
    """
    rng = np.random.default_rng(seed)
    force = multisine(P, FS, (0.5, 20.0), rms, rng, n_periods=N_PERIODS + TRANSIENT, kind=kind)
    response = simulate_response(*MCK, [2], force.fine, FS * force.oversample, force.oversample,
                                 CUBIC if k3 else [], [k3] if k3 else [])
    signals = Signals(force=response.force, displacement=add_output_noise(response.displacement, noise, rng),
                      fs=FS, input_dofs=(2,), output_dofs=(1, 2), period=P)
    return signals.segment(TRANSIENT * P, (N_PERIODS + TRANSIENT) * P)
