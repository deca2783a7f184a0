"""A carriage without spring held by a PD position loop (an EMPS-like free body), integrated independently.

``M q'' + Fv q' + Fc sign(q') + offset = tau``, semi-implicit Euler at ``sub`` times the output rate;
the true parameters are the reference values of the free-body tests.
"""

import numpy as np

MASS, FV, FC, OFFSET = 95.0, 200.0, 20.0, -3.0
FS = 200.0


def free_body_record(seed: int = 0, duration: float = 60.0, sub: int = 10):
    """Measured position (1 µm encoder-like noise) and applied force of the carriage, at ``FS``."""
    rng = np.random.default_rng(seed)
    n = int(duration * FS)
    h = 1.0 / (FS * sub)
    t = np.arange(n * sub) * h
    ref = sum(0.05 * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) for f in rng.uniform(0.1, 1.0, 5))
    disturbance = rng.normal(0.0, 5.0, n)
    kp, kv = 4000.0, 600.0
    q = v = tau = 0.0
    qs, taus = np.empty(n), np.empty(n)
    for k in range(n * sub):
        if k % sub == 0:
            tau = kp * (ref[k] - q) - kv * v + disturbance[k // sub]
            qs[k // sub], taus[k // sub] = q, tau
        v += h * (tau - FV * v - FC * np.sign(v) - OFFSET) / MASS
        q += h * v
    qs = qs + rng.normal(0.0, 1e-6, n)  # encoder-like measurement noise
    return qs, taus
