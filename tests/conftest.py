"""Shared fixtures: small dense configurations built without the engine."""

import numpy as np
import pytest

from fcsweep.model.lattice import hexagonal_lattice


def dense_config(N=36, seed=0, deform=0.12, jitter=0.1, M1=5, density=0.95):
    """Jittered hexagonal lattice of deformed cells with random polarity."""
    rng = np.random.default_rng(seed)
    pos, box = hexagonal_lattice(N, density)
    pos = np.mod(pos + rng.normal(0.0, jitter, pos.shape), box)
    theta = rng.uniform(0, 2 * np.pi, N)
    c = rng.normal(size=(N, M1)) + 1j * rng.normal(size=(N, M1))
    c *= deform / np.abs(c).sum(axis=1, keepdims=True) if M1 else 1.0
    return pos, theta, np.ascontiguousarray(c.real), np.ascontiguousarray(c.imag), box


@pytest.fixture
def dense():
    return dense_config()
