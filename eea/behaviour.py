"""Behaviour summaries and their similarity (paper section 3.1 and equation 2).

A *behaviour summary* is the magnitude of the discrete Fourier transform of each IMU
orientation series (roll, pitch, yaw in degrees, sampled every 0.01 s) of one experiment.
Two summaries are compared coefficient by coefficient with equation 2::

    sim(B, B') = 1/f * sum_k clip(1 - |c_k(B) - c_k(B')| / MAX, 0, 1),   MAX = 100

Scaling (docs/self_modeling.md): the coefficients are the *unnormalised* ``|numpy.fft.rfft|``
(a sum over samples, not divided by their number), so a sinusoid of amplitude A degrees
over N samples gives a peak of about A * N / 2. Normalised coefficients are so small next
to MAX = 100 that sim is about 0.999 for a healthy versus a damaged robot and the search is
blind; unnormalised ones keep differences of a few degrees visible (sim 0.87-0.94 in the
design prototype at 256 steps). The coefficients therefore grow with the number of steps,
and MAX must be read as "per N samples": compare only summaries of equal length.

**Signed zero-frequency term** (``signed=True``; ``EEAConfig.behaviour_summary =
"signed_dft"``; not the paper's). A magnitude cannot tell a series from its negation, so a
roll or turn to one side and the same roll or turn to the other give the same coefficients.
The zero-frequency coefficient of an rfft is real (the sum of the series); keeping its sign
tells the sides apart at no cost. Measured with servo gains in the model (docs/self_modeling.md,
"Gain signs: the trap and the way out"): alone it changes nothing significant; with the
CMA-ES gain flips it gets the pectoral gains' signs right on 4 of 4 seeds.

**Gyroscope rates** (``EEAConfig.behaviour_summary = "gyro_dft"``; a reading of the paper,
in measurement). The paper calls its signal "IMU readings for pitch, roll, yaw" and names mean
or RMS angular velocity as alternatives; this summary is the DFT magnitudes of the angular
rates (:func:`angular_rates`, degrees/s) instead of the angles. A rate is the angle's change
over 0.01 s, so its coefficients are about 100 times the change's; eq. 2 then uses MAX 1000
(:data:`MAX_COEFFICIENTS`), where no coefficient of the probe's robots clips
(docs/studies.md, "The signal").
"""

from __future__ import annotations

import numpy as np

__all__ = ["CHANNELS", "MAX_COEFFICIENT", "MAX_COEFFICIENTS", "SUMMARIES", "angular_rates", "behaviour_summary",
           "similarity", "summarise"]

#: Channel order of IMU logs and of behaviour summaries (kept as the simulator logs them).
CHANNELS: tuple[str, ...] = ("roll", "pitch", "yaw")
#: MAX of equation 2 (the paper's value).
MAX_COEFFICIENT: float = 100.0
#: Names of the behaviour summaries (:func:`summarise`): the paper's DFT magnitudes, those with
#: the zero-frequency term signed (``behaviour_summary(..., signed=True)``, not the paper's), or
#: the DFT magnitudes of the angular rates (a gyroscope's signal; :func:`angular_rates`).
SUMMARIES: tuple[str, ...] = ("dft", "signed_dft", "gyro_dft")
#: MAX of equation 2 for each summary: the paper's 100 for the angles' DFT; 1000 for the rates',
#: whose coefficients are about 100 times larger (one step is 0.01 s).
MAX_COEFFICIENTS: dict[str, float] = {"dft": MAX_COEFFICIENT, "signed_dft": MAX_COEFFICIENT, "gyro_dft": 1000.0}
#: Simulation step of an IMU log (s): one row every 0.01 s.
_STEP_S = 0.01


def behaviour_summary(imu_log, signed: bool = False) -> np.ndarray:
    """DFT magnitudes of roll, pitch and yaw series: the paper's behaviour summary.

    Every frequency bin is kept, the zero-frequency (sum) term included; with ``signed`` that
    term keeps its sign (it is the real sum of the series; not the paper's).

    Args:
        imu_log: ``(N, steps, 3)`` or ``(steps, 3)`` orientation in degrees, channels
            ``CHANNELS`` = (roll, pitch, yaw), one row per 0.01 s simulation step
            (steps >= 1, normally a power of two).

    Returns:
        ``(N, 3, steps // 2 + 1)`` (or ``(3, steps // 2 + 1)``) float64
        ``|rfft(series)|`` along time, unnormalised (degree-samples), channel order
        ``CHANNELS``; C-contiguous.

    Raises:
        ValueError: if ``imu_log`` is not 2-D or 3-D with 3 channels last, has no steps,
            or contains NaN or infinity.
    """
    log = _checked_log(imu_log)
    # C order: reductions over a summary (eq. 2) then add in the same order whatever the
    # batch it came from, so results are bit-for-bit independent of batching and workers.
    spectrum = np.fft.rfft(np.swapaxes(log, -1, -2), axis=-1)
    summary = np.abs(spectrum)
    if signed:
        summary[..., 0] = spectrum[..., 0].real
    return np.ascontiguousarray(summary)


def angular_rates(imu_log) -> np.ndarray:
    """Angular rates of an orientation log, a gyroscope's signal: each angle's change from the
    previous row over 0.01 s, the first row's rate 0.

    Args:
        imu_log: ``(N, steps, 3)`` or ``(steps, 3)`` roll, pitch, yaw in degrees (yaw unwrapped,
            as the simulator logs it), one row per 0.01 s.

    Returns:
        float64 array of ``imu_log``'s shape, degrees/s.

    Raises:
        ValueError: if ``imu_log`` is not 2-D or 3-D with 3 channels last, has no steps, or
            contains NaN or infinity.
    """
    log = _checked_log(imu_log)
    return np.diff(log, axis=-2, prepend=log[..., :1, :]) / _STEP_S


def summarise(imu_log, summary: str) -> np.ndarray:
    """The behaviour summary called ``summary`` (:data:`SUMMARIES`) of an IMU log.

    ``"dft"`` is :func:`behaviour_summary` (the paper's), ``"signed_dft"`` the same with the
    zero-frequency term signed, ``"gyro_dft"`` :func:`behaviour_summary` of the
    :func:`angular_rates`. Compare summaries with :func:`similarity` at
    ``MAX_COEFFICIENTS[summary]``.

    Args:
        imu_log: ``(N, steps, 3)`` or ``(steps, 3)`` orientation in degrees (see
            :func:`behaviour_summary`).
        summary: a name of :data:`SUMMARIES`.

    Returns:
        ``(N, 3, steps // 2 + 1)`` (or ``(3, steps // 2 + 1)``) float64 coefficients.

    Raises:
        ValueError: on an unknown summary name (the message lists the valid ones), or as
            :func:`behaviour_summary` does.
    """
    if summary not in SUMMARIES:
        raise ValueError(f"unknown behaviour summary {summary!r}; valid names: {', '.join(SUMMARIES)}")
    if summary == "gyro_dft":
        return behaviour_summary(angular_rates(imu_log))
    return behaviour_summary(imu_log, signed=summary == "signed_dft")


def similarity(a, b, max_coefficient: float = MAX_COEFFICIENT) -> np.ndarray:
    """Similarity of behaviour summaries, paper equation 2 (1 = identical, 0 = far apart).

    The mean over all f = 3 * F coefficients (every channel and frequency) of
    ``clip(1 - |c_k(a) - c_k(b)| / max_coefficient, 0, 1)``: a coefficient that differs
    by ``max_coefficient`` or more contributes 0, never a negative amount.

    Args:
        a: ``(..., 3, F)`` behaviour summaries (see :func:`behaviour_summary`).
        b: ``(..., 3, F)`` behaviour summaries; leading dimensions broadcast with ``a``'s,
            e.g. ``(P, 3, F)`` against ``(3, F)`` gives ``(P,)``.
        max_coefficient: MAX of equation 2, > 0 (paper: 100).

    Returns:
        ``(...)`` float64 similarities in [0, 1] (a 0-d ``numpy.float64`` for two single
        summaries).

    Raises:
        ValueError: if either input is not ``(..., 3, F)``, their last two dimensions
            differ, their leading dimensions do not broadcast, an input contains NaN or
            infinity, or ``max_coefficient`` is not a finite number > 0.
    """
    a, b = _checked(a, b, max_coefficient)
    terms = np.clip(1.0 - np.abs(a - b) / max_coefficient, 0.0, 1.0)
    return terms.mean(axis=(-2, -1))


def _checked_log(imu_log) -> np.ndarray:
    """``imu_log`` as float64, validated as :func:`behaviour_summary` documents."""
    log = np.asarray(imu_log, dtype=np.float64)
    if log.ndim not in (2, 3) or log.shape[-1] != len(CHANNELS):
        raise ValueError(
            f"imu_log must have shape (N, steps, 3) or (steps, 3) with channels {CHANNELS}, "
            f"got {log.shape}"
        )
    if log.shape[-2] == 0:
        raise ValueError("imu_log must have at least one step")
    if not np.all(np.isfinite(log)):
        raise ValueError("imu_log contains NaN or infinity")
    return log


def _checked(a, b, max_coefficient) -> tuple[np.ndarray, np.ndarray]:
    """``a`` and ``b`` as float64 arrays, validated as :func:`similarity` documents."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    for name, x in (("a", a), ("b", b)):
        if x.ndim < 2 or x.shape[-2] != len(CHANNELS) or x.shape[-1] == 0:
            raise ValueError(f"{name} must have shape (..., 3, F) with F >= 1, got {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError(f"{name} contains NaN or infinity")
    if a.shape[-2:] != b.shape[-2:]:
        raise ValueError(
            f"a and b must have the same (3, F) summary shape, got {a.shape} and {b.shape}"
        )
    try:
        np.broadcast_shapes(a.shape, b.shape)
    except ValueError:
        raise ValueError(
            f"leading dimensions of a {a.shape} and b {b.shape} do not broadcast"
        ) from None
    try:
        valid = bool(np.isfinite(max_coefficient) and max_coefficient > 0)
    except TypeError:
        valid = False
    if not valid:
        raise ValueError(f"max_coefficient must be a finite number > 0, got {max_coefficient!r}")
    return a, b
