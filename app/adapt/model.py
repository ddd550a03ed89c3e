"""The map-based Gaussian process of Intelligent Trial and Error (Cully et al., Nature 2015,
Methods, "M-BOA"): performance over the map's behaviour descriptors is a Gaussian process
whose prior mean is the map's own performance P(x), so that after trials chi_1..t with
measured performances y_1..t

    mu_t(x)      = P(x) + k(x)^T (K + s_n^2 I)^-1 (y - P(chi))
    sigma_t^2(x) = k(x, x) - k(x)^T (K + s_n^2 I)^-1 k(x)

with a Matern 5/2 kernel of length scale rho in descriptor units and unit signal variance,
and observation noise s_n^2. scikit-learn's GaussianProcessRegressor computes exactly this
on the residual y - P(chi) with its optimiser off (the published method fixes every
hyperparameter); ``posterior_reference`` is the same formula in plain numpy, which the tests
hold the fast path to.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import ConstantKernel, Matern


@dataclasses.dataclass(frozen=True)
class GPSettings:
    """ITE's published values: Matern nu = 5/2, length scale 0.4 in descriptor space
    (each descriptor in [0, 1]), signal variance 1, noise variance 0.001."""

    length_scale: float = 0.4
    noise: float = 0.001
    signal_variance: float = 1.0


def _regressor(g: GPSettings) -> GaussianProcessRegressor:
    kernel = ConstantKernel(g.signal_variance, constant_value_bounds="fixed") * \
        Matern(length_scale=g.length_scale, length_scale_bounds="fixed", nu=2.5)
    return GaussianProcessRegressor(kernel=kernel, alpha=g.noise, optimizer=None, normalize_y=False)


@dataclasses.dataclass(frozen=True)
class Posterior:
    """mu and sigma (N,) over the map's elites, and the log marginal likelihood of the
    trials under this prior (0 before any trial): how well the map explains them."""

    mean: np.ndarray
    std: np.ndarray
    log_likelihood: float


def posterior(descriptors: np.ndarray, prior_mean: np.ndarray, tried_x: np.ndarray, tried_prior: np.ndarray,
              measured: np.ndarray, g: GPSettings = GPSettings()) -> Posterior:
    """The posterior over ``descriptors`` (N, d) of a map whose performance there is
    ``prior_mean`` (N,), after trials at ``tried_x`` (t, d) whose prior performance was
    ``tried_prior`` (t,) and measured ``measured`` (t,)."""
    X = np.asarray(descriptors, dtype=float)
    mu0 = np.asarray(prior_mean, dtype=float)
    if len(measured) == 0:
        return Posterior(mu0.copy(), np.full(len(X), np.sqrt(g.signal_variance)), 0.0)
    gp = _regressor(g)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        gp.fit(np.asarray(tried_x, dtype=float), np.asarray(measured, dtype=float) - np.asarray(tried_prior, dtype=float))
    m, s = gp.predict(X, return_std=True)
    return Posterior(mu0 + m, s, float(gp.log_marginal_likelihood_value_))


def matern52(a: np.ndarray, b: np.ndarray, length_scale: float, variance: float = 1.0) -> np.ndarray:
    d = np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(-1)) / length_scale
    return variance * (1.0 + np.sqrt(5.0) * d + 5.0 / 3.0 * d * d) * np.exp(-np.sqrt(5.0) * d)


def posterior_reference(descriptors, prior_mean, tried_x, tried_prior, measured, g: GPSettings = GPSettings()):
    """The M-BOA formulas above, written out (slow; for the tests)."""
    X, T = np.asarray(descriptors, float), np.asarray(tried_x, float)
    r = np.asarray(measured, float) - np.asarray(tried_prior, float)
    K = matern52(T, T, g.length_scale, g.signal_variance) + g.noise * np.eye(len(T))
    k = matern52(X, T, g.length_scale, g.signal_variance)
    Kinv = np.linalg.inv(K)
    mean = np.asarray(prior_mean, float) + k @ Kinv @ r
    var = g.signal_variance - np.einsum("ij,jk,ik->i", k, Kinv, k)
    sign, logdet = np.linalg.slogdet(K)
    ll = -0.5 * r @ Kinv @ r - 0.5 * logdet - 0.5 * len(T) * np.log(2 * np.pi)
    return mean, np.sqrt(np.maximum(var, 0.0)), float(ll)
