"""Accuracy measures of trajectories: energy variation, unit-length error, orders, momenta.

Input: arrays from a `Trajectory` (q: (N+1, n, 3), energy: (N+1,)). Output: floats.

Definitions used throughout (and in the reports):

- energy variation: |E_k - E_0| over all samples k = 0..N (t = 0 included);
- unit-length error: |‖q_i‖ - 1| (the geometric one) and |q_i.q_i - 1| (about twice as large;
  the definition the paper's printed numbers follow), averaged over samples and bodies.

Example:
    >>> import numpy as np
    >>> energy_variation(np.array([1.0, 1.5, 0.5]))
    (0.3333333333333333, 0.5)
"""

from __future__ import annotations

import numpy as np

__all__ = ["energy_variation", "observed_order", "summary", "unit_length_error"]


def energy_variation(energy: np.ndarray) -> tuple[float, float]:
    """(mean, max) of |E_k - E_0| over all samples."""
    dev = np.abs(np.asarray(energy) - energy[0])
    return float(np.mean(dev)), float(np.max(dev))


def unit_length_error(q: np.ndarray) -> dict[str, float]:
    """Mean and max of |‖q_i‖ - 1|, and mean and max of |q_i.q_i - 1|, over samples and bodies."""
    qq = np.einsum("...c,...c->...", q, q)
    norm_err = np.abs(np.sqrt(qq) - 1.0)
    dot_err = np.abs(qq - 1.0)
    return {
        "mean_norm": float(np.mean(norm_err)),
        "max_norm": float(np.max(norm_err)),
        "mean_dot": float(np.mean(dot_err)),
        "max_dot": float(np.max(dot_err)),
    }


def observed_order(hs: np.ndarray, errors: np.ndarray) -> float:
    """Least-squares slope of log(error) against log(h)."""
    slope, _ = np.polyfit(np.log(np.asarray(hs)), np.log(np.asarray(errors)), 1)
    return float(slope)


def summary(q: np.ndarray, energy: np.ndarray) -> dict[str, float]:
    """Energy variation and unit-length error of one trajectory, in one dictionary."""
    mean_e, max_e = energy_variation(energy)
    return {"mean_dE": mean_e, "max_dE": max_e, **unit_length_error(q)}
