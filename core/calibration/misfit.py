"""When a calibration should not be believed, said in words.

:func:`fit_diagnosis` compares the least-squares residual of a log with the noise the user
stated, and the manoeuvre's rank with the 12 coefficients, and returns sentences that name
what to check: the readings' unit, the attitude convention (every one of :data:`CONVENTIONS`
is tried and the one that fits is named), Be, or the stated noise (with σ estimated from the
residuals); or which coefficients a rank-deficient manoeuvre leaves unbounded. The CLI prints
the sentences and the Calibration tab shows them. Cost: a few least-squares fits, linear in N.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .estimators import lsq_calibrate
from .model import CHUNK, COEFFICIENTS, CONVENTIONS, _attitude, _convention
from .observability import calibration_observability
from .validation import (
    _K,
    NOISE_RANGE_NT,
    _attitudes,
    _min_attitudes,
    _readings,
    checked_angle_noise,
    checked_be,
    checked_noise,
)

#: σ̂ / σ above this (at least; more for few readings, see :func:`fit_diagnosis`) says the
#: readings are noisier than stated, so the CRLB for σ is optimistic.
NOISY_RATIO = 1.5
#: σ̂ / σ above this says the model does not describe the readings at all (a wrong unit, attitude
#: convention or Be, or a file that is not a calibration log), not merely a noisier sensor.
MISFIT_RATIO = 10.0
#: Upper 0.1 % point of the standard normal (for the χ² threshold of few degrees of freedom).
_Z999 = 3.090232306167813


@dataclass(frozen=True)
class FitDiagnosis:
    """How well the model B = K·A·Be + Bp fits a log (:func:`fit_diagnosis`).

    Attributes
    ----------
    level : {"ok", "note", "warning", "misfit"}
        The most serious finding: ``"misfit"`` the model does not fit (the estimates mean
        nothing), ``"warning"`` the bounds or some coefficients cannot be trusted (noisier than
        stated, rank < 12), ``"note"`` worth knowing (too few readings to test the fit, noise
        overstated), ``"ok"`` nothing to say.
    messages : tuple of str
        Sentences, the most serious first; empty when ``level == "ok"``.
    residual_rms_nt : float
        RMS of the least-squares residual over all 3N readings (nT).
    sigma_nt : float
        The stated per-reading noise, angle errors included (nT): √(σ_B² + σ_a²·mean‖J‖²/3).
    sigma_hat_nt : float
        σ estimated from the residuals, √(Σ r² / (3N − rank)) (nT); NaN when 3N = rank.
    ratio : float
        sigma_hat_nt / sigma_nt (NaN when 3N = rank).
    threshold : float
        The ratio above which the readings are called noisier than stated (≥ NOISY_RATIO).
    dof : int
        Degrees of freedom of the residual, 3N − rank.
    rank : int
        Rank of Γ of the attitudes as recorded.
    unbounded : tuple of str
        Coefficients (names of :data:`COEFFICIENTS`) the manoeuvre does not determine.
    convention_rms_nt : dict
        Least-squares residual RMS (nT) under each attitude convention (all of them are tried
        when the fit is poor; otherwise only the one used).
    best_convention : str
        The convention with the smallest residual.
    suggested_convention : str or None
        Another convention worth using: the one with which the model fits (a misfit), or one
        that fits clearly better (a poor fit); None otherwise.
    suggested_be : tuple of float or None
        Be (nT) with a common slip undone (down negated, north and east swapped) when that
        makes the model fit; None otherwise.
    reading_sigma_hat_nt : float
        The reading noise σ_B the residuals give, the stated angle errors' share taken out:
        √(σ̂² − σ_a²·mean‖J‖²/3) (nT); NaN when 3N = rank or the angle errors alone explain the
        residual. What to state as the noise when :attr:`noise_misstated`.
    """

    level: str
    messages: tuple
    residual_rms_nt: float
    sigma_nt: float
    sigma_hat_nt: float
    ratio: float
    threshold: float
    dof: int
    rank: int
    unbounded: tuple
    convention_rms_nt: dict
    best_convention: str
    suggested_convention: object = None
    suggested_be: object = None
    reading_sigma_hat_nt: float = float("nan")

    @property
    def noise_misstated(self):
        """Whether the stated noise is off by more than chance (σ̂/σ outside [1/threshold,
        threshold]) while the model fits (σ̂/σ ≤ :data:`MISFIT_RATIO`): then the CRLB for
        :attr:`reading_sigma_hat_nt` is the honest bound, and the one for the stated σ is
        optimistic (or pessimistic) by about σ̂/σ. False for a misfit: no noise level makes the
        bounds of a model that does not fit mean anything."""
        return bool(self.dof > 0 and np.isfinite(self.ratio) and self.ratio <= MISFIT_RATIO
                    and not 1.0 / self.threshold <= self.ratio <= self.threshold
                    and np.isfinite(self.reading_sigma_hat_nt))


def _noise_threshold(dof):
    """σ̂/σ exceeded with probability 0.1 % when σ is right (Gaussian readings): √(χ²₀.₉₉₉/dof)
    by the Wilson–Hilferty approximation (within ~1 % for dof ≥ 3), and at least NOISY_RATIO."""
    a = 2.0 / (9.0 * dof)
    return max(NOISY_RATIO, float(np.sqrt((1.0 - a + _Z999 * np.sqrt(a)) ** 3)))


def _angle_variance(att, be, K, factors):
    """mean over attitudes of ‖J_n‖²_F / 3, J_n = K ∂(A Be)/∂(ψ, θ, φ) (nT²/rad²), in blocks."""
    total = 0.0
    for a in range(0, att.shape[0], CHUNK):
        _, dA = _attitude(att[a:a + CHUNK], factors)
        J = np.einsum("ij,nkjl,l->nik", K, dA, be)
        total += float(np.sum(J ** 2))
    return total / (3.0 * att.shape[0])


def _fmt(x):
    return f"{x:,.0f}".replace(",", " ") if abs(x) >= 100 else f"{x:.3g}"


def fit_diagnosis(B, attitudes, be, *, noise_nt, angle_noise_rad=0.0, convention="seed004"):
    """Does the model fit the readings, and does the manoeuvre determine the 12 coefficients?

    Parameters
    ----------
    B : array_like, shape (N, 3)
        Readings (nT), N ≥ 4.
    attitudes : array_like, shape (N, 3)
        ψ, θ, φ (rad) as recorded.
    be : array_like, shape (3,)
        Geomagnetic field north, east, down (nT).
    noise_nt : float
        The stated standard deviation of each reading's noise (nT), > 0.
    angle_noise_rad : float
        The stated standard deviation of each angle's error (rad), ≥ 0.
    convention : str
        The attitude convention used (a key of :data:`CONVENTIONS`).

    Returns
    -------
    FitDiagnosis

    Notes
    -----
    With the stated noise right, the least-squares residual gives σ̂² = Σ r² / (3N − rank) ≈ σ²
    (σ² including the linearised angle errors, as :func:`calibration_covariance` has them).
    σ̂/σ above :func:`_noise_threshold` (1.5, more for < 24 degrees of freedom: a 0.1 % false
    alarm rate for Gaussian errors) means noisier than stated: the CRLB for σ is optimistic by
    about σ̂/σ. Above :data:`MISFIT_RATIO` the model does not describe the readings; then each
    attitude convention, and Be with its down component negated or north and east swapped, is
    tried, and any that brings σ̂/σ under the threshold is named. A rank below 12 names the
    unbounded coefficients: their estimates are one of infinitely many that fit equally well.

    Examples
    --------
    >>> import numpy as np, core
    >>> att = core.heading_manoeuvre(roll_deg=10, pitch_deg=5, n_attitudes=12)
    >>> B = core.ship_field(np.eye(3), [100, 200, 300], att, [34000, 2000, 35000])
    >>> core.fit_diagnosis(B + 1.0, att, [34000, 2000, 35000], noise_nt=100).level
    'note'
    """
    att = _attitudes(attitudes, one="log")
    _min_attitudes(att)
    B = _readings(B, att)
    be = checked_be(be)
    sb = checked_noise("noise_nt", noise_nt)
    sa = checked_angle_noise("angle_noise_rad", angle_noise_rad)
    factors = _convention(convention)
    N = att.shape[0]
    lsq = lsq_calibrate(B, att, be, convention=convention)
    var = sb ** 2
    if sa > 0:
        var += sa ** 2 * _angle_variance(att, be, _K(lsq.K), factors)
    sigma = float(np.sqrt(var))
    obs = calibration_observability(att, be, convention=convention)
    rank = obs.rank
    dof = 3 * N - rank
    rms = float(lsq.residual_rms_nt)
    sigma_hat = float(rms * np.sqrt(3 * N / dof)) if dof > 0 else float("nan")
    ratio = sigma_hat / sigma if dof > 0 else float("nan")
    threshold = _noise_threshold(dof) if dof > 0 else float("nan")
    conv_rms = {convention: rms}
    suggest_conv = suggest_be = None
    unbounded = tuple(c for c, ok in zip(COEFFICIENTS, obs.observable) if not ok)
    msgs = {"misfit": [], "warning": [], "note": []}

    # 1. the fit: residual against the stated noise
    if dof == 0:
        msgs["note"].append(
            f"{N} attitudes give {3 * N} readings for {rank} determined coefficients: least squares "
            "fits them exactly whatever the noise, so the residual cannot tell whether the model "
            "fits; add attitudes to check it.")
    elif ratio > threshold:
        for name in CONVENTIONS:
            if name not in conv_rms:
                conv_rms[name] = float(lsq_calibrate(B, att, be, convention=name).residual_rms_nt)
        best = min(conv_rms, key=conv_rms.get)
        fits = lambda r: r * np.sqrt(3 * N / dof) / sigma <= threshold  # noqa: E731
        times = f"{ratio:,.0f}".replace(",", " ") if ratio >= 100 else f"{ratio:.3g}"
        said = f"the residual RMS is {_fmt(rms)} nT, {times} × the stated noise σ = {_fmt(sigma)} nT"
        if ratio > MISFIT_RATIO:
            size = float(np.median(np.linalg.norm(B, axis=-1)))
            norm = float(np.linalg.norm(be))
            unit = (f"the unit of B (nT expected: the readings' median magnitude is {_fmt(size)} nT "
                    f"against |Be| = {_fmt(norm)} nT"
                    + (", another unit?" if not 1 / 3 < size / norm < 3 else "") + ") and of the angles (rad)")
            # the conventions and two common slips in Be, every pair: the one that fits is named
            variants = {"": be, "Be's down component negated (z up?)": be * [1, 1, -1],
                        "Be's north and east swapped": be[[1, 0, 2]]}
            tried = {(c, ""): r for c, r in conv_rms.items()}
            for what, alt in list(variants.items())[1:]:
                for name in CONVENTIONS:
                    tried[name, what] = float(
                        lsq_calibrate(B, att, alt, convention=name).residual_rms_nt)
            (c_fit, be_fit), r_fit = min(tried.items(), key=lambda kv: kv[1])
            if fits(r_fit) and (c_fit, be_fit) != (convention, ""):
                suggest_conv = c_fit if c_fit != convention else None
                suggest_be = tuple(float(v) for v in variants[be_fit]) if be_fit else None
                change = [f"the '{c_fit}' attitude convention"] * (c_fit != convention)
                change += [be_fit] * bool(be_fit)
                checks = [unit, "the attitude convention and Be: with " + " and ".join(change)
                          + f" the model fits (residual RMS {_fmt(r_fit)} nT)"]
            else:
                checks = [unit, "the attitude convention (none of " + ", ".join(CONVENTIONS)
                          + f" fits better than {_fmt(conv_rms[best])} nT)",
                          f"Be = [{', '.join(_fmt(v) for v in be)}] nT (north, east, down)"]
            msgs["misfit"].append(
                f"The model does not fit these readings: {said}, so K, Bp and the bounds mean "
                "nothing. Check " + "; ".join(checks) + ".")
        else:
            better = ""
            if best != convention and conv_rms[best] < 0.9 * rms:
                better = (f" The '{best}' attitude convention fits better ({_fmt(conv_rms[best])} nT).")
                suggest_conv = best
            msgs["warning"].append(
                f"{said[0].upper()}{said[1:]}: either the readings are noisier than stated, and then the CRLB for σ is "
                f"optimistic by about {ratio:.2g}×: with σ estimated from the residuals, "
                f"σ̂ = {_fmt(sigma_hat)} nT, the bounds are {ratio:.2g}× "
                "larger; or the model does not fully describe them (attitude convention, Be, "
                f"unmodelled interference).{better}")
    elif ratio < 1.0 / threshold:
        msgs["note"].append(
            f"The residual RMS is {_fmt(rms)} nT, only {ratio:.2g} × the stated noise σ = "
            f"{_fmt(sigma)} nT: the readings are less noisy than stated, so the CRLB for σ is "
            f"pessimistic; σ estimated from the residuals is σ̂ = {_fmt(sigma_hat)} nT.")
    # 2. the manoeuvre: what it does not determine
    if unbounded:
        msgs["warning"].append(
            f"The manoeuvre determines only {rank} of the 12 coefficients: {', '.join(unbounded)} "
            "are unbounded (CRLB ∞); their estimates are one of infinitely many that fit these "
            "readings equally well, however small the residual. "
            + " ".join(d[0].upper() + d[1:] + "." for d in obs.descriptions)
            + " Add roll or pitch that varies between attitudes.")
    level = next((k for k in ("misfit", "warning", "note") if msgs[k]), "ok")
    messages = tuple(m for k in ("misfit", "warning", "note") for m in msgs[k])
    angle_var = var - sb ** 2  # the stated angle errors' share of σ² (nT²)
    reading = (float(np.sqrt(sigma_hat ** 2 - angle_var)) if dof > 0 and sigma_hat ** 2 > angle_var
               else float("nan"))
    if not NOISE_RANGE_NT[0] <= reading <= NOISE_RANGE_NT[1]:  # (also NaN)
        reading = float("nan")
    return FitDiagnosis(level, messages, rms, sigma, sigma_hat, ratio, threshold, dof, rank,
                        unbounded, conv_rms, min(conv_rms, key=conv_rms.get), suggest_conv,
                        suggest_be, reading)
