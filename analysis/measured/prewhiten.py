"""Pre-whitening of a vibration record before envelope analysis: remove the discrete
(deterministic) lines and the structure's colouring, so that the band search and the
envelope see the impacts.

* ``cepstrum``: cepstral pre-whitening (R. B. Randall, N. Sawalhi, "A new method for
  separating discrete components from a signal", Sound and Vibration 45 (2011) 6–9; used on
  the whole CWRU data set by W. A. Smith, R. B. Randall, MSSP 64–65 (2015) 100–131):
  setting the real cepstrum to zero except at quefrency 0 is the same as keeping the phase
  of the spectrum with unit magnitude, x_w = IFFT(exp(i·∠X)). One FFT pair; no parameter.
* ``ar``: linear prediction (J. Antoni, R. B. Randall; N. Sawalhi, R. B. Randall, MSSP 21
  (2007)): an autoregressive model of order p fitted by the Yule–Walker equations (solved
  by Levinson recursion, ``scipy.linalg.solve_toeplitz``), the record replaced by its
  prediction error, which holds what the model cannot predict, the impacts.
* ``none``: the record as it is (mean removed).

Both remove a stationary colouring; cepstral whitening also flattens the resonance the
impacts ring, so the band search then judges the impulsiveness alone.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.fft
import scipy.linalg
import scipy.signal

from analysis.errors import InputError

METHODS = ("cepstrum", "ar", "none")
"""The pre-whitening methods (``--prewhiten``)."""
DEFAULT = "cepstrum"
"""The default method: cepstral pre-whitening (robust on the CWRU data, Smith & Randall
2015, and on the synthetic tests of tests/measured/test_diagnose.py)."""
AR_ORDER_S = 0.004
"""The AR model's memory (s): its order is this many seconds of samples (at most
``AR_MAX_ORDER``); long enough to model a resonance's ringing of a few ms, short against
the time between impacts."""
AR_MAX_ORDER = 200
"""The largest AR order."""


def check_method(method: str) -> str:
    """``method`` when it is one of :data:`METHODS`; InputError naming ``prewhiten`` (the
    parameter of ``diagnose`` that gives it) otherwise."""
    if method not in METHODS:
        raise InputError(f"prewhiten: must be {', '.join(METHODS[:-1])} or {METHODS[-1]}, "
                         f"got {method!r}", field="prewhiten")
    return method


def cepstral(values: np.ndarray) -> np.ndarray:
    """Cepstral pre-whitening: the real inverse FFT of exp(i·∠X), X the FFT of the
    mean-free record (unit magnitude in every bin; the DC bin set to 0)."""
    x = np.asarray(values, dtype=float)
    spectrum = scipy.fft.rfft(x - x.mean())
    magnitude = np.abs(spectrum)
    whitened = np.divide(spectrum, magnitude, out=np.zeros_like(spectrum),
                         where=magnitude > 0)
    whitened[0] = 0.0
    return scipy.fft.irfft(whitened, n=x.size)


def ar_order(fs: float, n_samples: int) -> int:
    """The AR order: ``AR_ORDER_S`` seconds of samples, at least 8, at most
    ``AR_MAX_ORDER`` and a tenth of the record."""
    return int(max(8, min(AR_MAX_ORDER, round(AR_ORDER_S * fs), n_samples // 10)))


def autoregressive(values: np.ndarray, order: int) -> np.ndarray:
    """The prediction error of the order-``order`` AR model of the mean-free record fitted
    by Yule–Walker (biased autocorrelation, Levinson recursion)."""
    x = np.asarray(values, dtype=float)
    x = x - x.mean()
    n = x.size
    n_fft = scipy.fft.next_fast_len(2 * n, real=True)
    power = np.abs(scipy.fft.rfft(x, n_fft)) ** 2
    r = scipy.fft.irfft(power, n_fft)[:order + 1] / n
    if not r[0] > 0:
        return x
    r[0] *= 1.0 + 1e-9  # a white-noise floor of 1e-9: the system stays positive definite
    a = scipy.linalg.solve_toeplitz(r[:order], r[1:order + 1])
    return scipy.signal.lfilter(np.concatenate([[1.0], -a]), [1.0], x)


def prewhiten(values: np.ndarray, fs: float, method: str = DEFAULT) -> np.ndarray:
    """The record pre-whitened by ``method`` (:data:`METHODS`); mean-free."""
    check_method(method)
    x = np.asarray(values, dtype=float)
    if method == "cepstrum":
        return cepstral(x)
    if method == "ar":
        return autoregressive(x, ar_order(fs, x.size))
    return x - x.mean()


def kurtosis(values: np.ndarray) -> float:
    """Excess kurtosis of a record (0 for Gaussian noise): how impulsive it is."""
    x = np.asarray(values, dtype=float)
    x = x - x.mean()
    m2 = float(np.mean(x * x))
    return float(np.mean(x**4) / (m2 * m2) - 3.0) if m2 > 0 else math.nan
