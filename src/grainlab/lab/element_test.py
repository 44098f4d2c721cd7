"""The element-test driver: run a :class:`~grainlab.lab.load_path.LoadPath` on a specimen.

Every element test is one mixed stress/strain control (STYLE.md 9; MercuryDPM's
StressStrainControlBoundary, YADE's stress mask). For each step of a stage the driver

1. expresses the specimen's tangent D (Voigt, engineering shears) in the stage's control
   frame, ``D* = B D B^T`` with ``B = Q T_sigma(R)`` (:func:`stress_rotation`; the strain
   transforms with ``B^-T = Q T_eps(R)``, :func:`strain_rotation`), so that c = B sigma and
   e = B^-T eps are work-conjugate;
2. solves the mixed system for the unknown strain increments: with E the strain-controlled
   and S the stress-controlled components,
   ``D*_SS de_S = (target_S - c_S) - D*_SE de_E`` where ``c_S`` is the current generalised
   stress (so the error left by the previous step is carried into this one);
3. applies ``deps = B^T de`` (lab frame), then *iterates* on S: the stress error
   ``r_S = target_S - c_S`` after the step is removed by corrections ``D*_SS de_S = r_S``
   (de_E = 0) until ``|r| <= tolerance max(|sigma|, |target_S|) + absolute_tolerance``, at most
   ``max_iterations`` times. The count is recorded per step (``iterations``, ``converged``,
   ``stress_error``) and summed in the outcome; a step left unconverged is never silent
   (columns, outcome and one :class:`~grainlab.errors.GrainlabWarning` per test).

Sub-stepping. A specimen cannot undo an increment, so steps are cut *before* they are applied:
a step with stress-controlled components is applied in pieces, a fraction h of it each, each
predicted with the tangent at its start (the first piece carries the error of the previous
step; later pieces follow the tangent's predicted path, the corrections of step 3 remove what
the prediction missed). h is halved for the next piece when the tangent changed by more than
``substep_threshold`` (relative norm) across the last piece, i.e. where the response is
strongly nonlinear, at most ``max_halvings`` times (h >= 2^-max_halvings), and doubles back
where the tangent is steady. When a correction makes the error grow (a tangent that
overestimates the compliance), the corrections are halved (damped) from then on, doubling back
after corrections that cut the error fourfold; after ``max_halvings`` halvings the test fails.

Failure. The test ends with ``outcome["status"] = "failure"`` when the specimen raises
:class:`~grainlab.errors.StrengthReached` (it has no stiffness state left), when the
stress-controlled block D*_SS is singular or not positive definite (min eigenvalue of its
symmetric part <= ``singular_tolerance`` x the largest |diagonal entry| of D*: the strength
is reached, halving
cannot help because the tangent is that of the current state), when the error keeps growing
after ``max_halvings`` halvings, or when ``max_iterations`` corrections did not reduce it.
Otherwise ``"completed"``. A step that changed the specimen before the failure is recorded.

One row per step (plus row 0, stage ``"initial"``): ``increment`` (global), ``stage``,
``step`` (within the stage), the lab-frame stresses ``sigma_xx``... and strains
``eps_xx``... ``gamma_xy``, the stress and strain invariants of every specimen
(:mod:`grainlab.result.invariants`: ``sigma_1`` >= ``sigma_2`` (3D) >= ``sigma_3``, ``p``
(trace/3 in 3D, trace/2 in 2D), ``q`` = sigma_1 - sigma_3, ``q_over_3``, ``q_over_trace``,
``sin_phi``, ``stress_ratio`` = sigma_1/sigma_3, ``b`` (3D), ``eps_vol`` (trace), ``eps_q``),
``frame_angle`` [rad], ``sub_steps``, ``iterations``, ``stress_error`` (relative),
``converged``, then ``specimen.descriptors()``; names and units in
:mod:`grainlab.result.columns`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from grainlab.errors import GrainlabWarning, InputError, StrengthReached
from grainlab.lab.load_path import LoadPath, LoadStage
from grainlab.lab.specimen import ElementSpecimen, voigt_labels, voigt_to_tensor
from grainlab.result.invariants import strain_invariants, stress_invariants
from grainlab.result.test_result import TestResult

_PAIRS = {
    3: ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)),
    2: ((0, 0), (1, 1), (0, 1)),
}
"""Voigt index -> tensor index pair (same order as :mod:`grainlab.lab.specimen`)."""

_UNCONVERGED_LISTED = 50


def stress_rotation(rotation: np.ndarray) -> np.ndarray:
    """Voigt matrix T_sigma (n, n) with sigma' = T_sigma sigma, the stress components in the
    frame whose basis vectors are the columns of ``rotation`` R (sigma' = R^T sigma R).

    For Voigt indices I = (i, j), J = (k, l):
    T[I, J] = R_ki R_lj for k = l, and R_ki R_lj + R_li R_kj for k != l (sigma_kl = sigma_lk
    both stand in sigma_J).

    >>> c = np.cos(0.3); s = np.sin(0.3)
    >>> T = stress_rotation(np.array([[c, -s], [s, c]]))
    >>> bool(np.allclose(T[0], [c * c, s * s, 2 * c * s]))
    True
    """
    r = np.asarray(rotation, dtype=float)
    pairs = _PAIRS[r.shape[0]]
    t = np.empty((len(pairs), len(pairs)))
    for a, (i, j) in enumerate(pairs):
        for b, (k, m) in enumerate(pairs):
            t[a, b] = r[k, i] * r[m, j] + (r[m, i] * r[k, j] if k != m else 0.0)
    return t


def strain_rotation(rotation: np.ndarray) -> np.ndarray:
    """Voigt matrix T_eps (n, n) with eps' = T_eps eps for strains with *engineering* shears
    (gamma = 2 eps) in the frame of ``rotation`` R (eps' = R^T eps R).

    T_eps[I, J] = w_I R_ki R_lj (k = l) or w_I (R_ki R_lj + R_li R_kj)/2 (k != l), with
    w_I = 1 for normal and 2 for shear rows. It equals T_sigma^-T (work conjugacy:
    sigma' . eps' = sigma . eps).
    """
    r = np.asarray(rotation, dtype=float)
    pairs = _PAIRS[r.shape[0]]
    t = np.empty((len(pairs), len(pairs)))
    for a, (i, j) in enumerate(pairs):
        weight = 1.0 if i == j else 2.0
        for b, (k, m) in enumerate(pairs):
            value = r[k, i] * r[m, j] if k == m else 0.5 * (r[k, i] * r[m, j] + r[m, i] * r[k, j])
            t[a, b] = weight * value
    return t


def control_matrix(stage: LoadStage, step: float) -> np.ndarray:
    """B = Q T_sigma(R) (n, n) of ``stage`` at the end of (fractional) ``step``.

    The generalised stress is c = B sigma and the generalised strain e = B^-T eps with
    B^-T = Q T_eps(R), so a lab strain increment is deps = B^T de.
    """
    return stage.basis @ stress_rotation(stage.rotation(step))


class ControlFrame:
    """The control matrices of one stage: computed once when the frame does not rotate."""

    def __init__(self, stage: LoadStage) -> None:
        self.stage = stage
        self.fixed = control_matrix(stage, 0.0) if stage.rotation_per_step == 0.0 else None

    def matrix(self, step: float) -> np.ndarray:
        """B of :func:`control_matrix` at the end of (fractional) ``step``."""
        return self.fixed if self.fixed is not None else control_matrix(self.stage, step)


# -- outcome ------------------------------------------------------------------------------------
class _Failure(Exception):
    """Internal: the step cannot be completed; ``applied`` says whether the specimen moved."""

    def __init__(self, reason: str, applied: bool):
        super().__init__(reason)
        self.reason = reason
        self.applied = applied
        self.report: _StepReport | None = None


@dataclass
class _StepReport:
    sub_steps: int = 0
    iterations: int = 0
    error: float = 0.0
    converged: bool = True


@dataclass
class _Controller:
    """Numerical settings and the adaptive piece size h (the driver's only state)."""

    max_iterations: int
    tolerance: float
    absolute_tolerance: float
    max_halvings: int
    substep_threshold: float
    singular_tolerance: float
    piece: float = 1.0
    damping: float = 1.0
    last_tangent: np.ndarray | None = None
    totals: dict[str, int] = field(default_factory=lambda: {"halvings": 0})

    def adapt_piece(self, tangent: np.ndarray) -> None:
        """Halve the piece size when the tangent changed by more than ``substep_threshold``
        (relative Frobenius norm) since the start of the last piece; double it back when it
        changed by less than a quarter of that."""
        if self.last_tangent is not None:
            before = float(np.linalg.norm(self.last_tangent))
            change = float(np.linalg.norm(tangent - self.last_tangent))
            if change > self.substep_threshold * before:
                if self.piece > self.smallest_piece:
                    self.piece /= 2.0
                    self.totals["halvings"] += 1
            elif change <= 0.25 * self.substep_threshold * before:
                self.piece = min(1.0, 2.0 * self.piece)
        self.last_tangent = tangent

    @property
    def smallest_piece(self) -> float:
        return 2.0 ** (-self.max_halvings)

    def check_block(self, d_star: np.ndarray, stress: np.ndarray) -> None:
        """Raise _Failure(applied=False) when D*_SS is singular or not positive definite."""
        if not stress.any():
            return
        if not np.all(np.isfinite(d_star)):
            raise _Failure("the specimen's tangent is not finite", applied=False)
        block = d_star[np.ix_(stress, stress)]
        scale = float(np.max(np.abs(np.diag(d_star))))
        lowest = float(np.min(np.linalg.eigvalsh(0.5 * (block + block.T))))
        if scale <= 0.0 or lowest <= self.singular_tolerance * scale:
            raise _Failure(
                "strength reached: the stress-controlled block of the tangent is singular or "
                f"not positive definite (smallest eigenvalue {lowest:.6g} Pa, "
                f"largest diagonal stiffness {scale:.6g} Pa)", applied=False)

    def allowed(self, sigma: np.ndarray, target: np.ndarray) -> float:
        return (self.tolerance * max(float(np.linalg.norm(sigma)), float(np.linalg.norm(target)))
                + self.absolute_tolerance)


def _solve_mixed(d_star: np.ndarray, stress: np.ndarray, de_known: np.ndarray,
                 dc_wanted: np.ndarray) -> np.ndarray:
    """Generalised strain increment de (n,) with de_E = de_known_E and
    (D* de)_S = dc_wanted_S."""
    de = np.where(stress, 0.0, de_known)
    if stress.any():
        strain = ~stress
        rhs = dc_wanted[stress] - d_star[np.ix_(stress, strain)] @ de[strain]
        de[stress] = np.linalg.solve(d_star[np.ix_(stress, stress)], rhs)
    return de


def _advance(specimen: ElementSpecimen, stage: LoadStage, k: int, targets: np.ndarray,
             de_step: np.ndarray, ctl: _Controller, frame: ControlFrame) -> _StepReport:
    """Run step k of ``stage``; raise _Failure (carrying the partial report) on failure."""
    report = _StepReport()
    try:
        try:
            return _advance_step(specimen, stage, k, targets, de_step, ctl, report, frame)
        except StrengthReached as lost:  # the specimen itself has no state left to go to
            raise _Failure(f"strength reached: {lost}",
                           applied=report.sub_steps > 0 or report.iterations > 0) from None
    except _Failure as failure:
        report.converged = False
        failure.report = report
        raise


def _relative(error: float, sigma: np.ndarray, target: np.ndarray) -> float:
    scale = max(float(np.linalg.norm(sigma)), float(np.linalg.norm(target)))
    return error / scale if scale > 0.0 else error


def _advance_step(specimen: ElementSpecimen, stage: LoadStage, k: int, targets: np.ndarray,
                  de_step: np.ndarray, ctl: _Controller, report: _StepReport,
                  frame: ControlFrame) -> _StepReport:
    stress = stage.stress_controlled
    done = 0.0
    reference = specimen.stress()  # lab stress along the tangent's prediction
    while done < 1.0 - 1e-12:
        tangent = np.array(specimen.tangent(), dtype=float)  # a copy: kept as last_tangent
        ctl.adapt_piece(tangent)
        h = min(ctl.piece, 1.0 - done) if stress.any() else 1.0 - done
        end = done + h
        b = frame.matrix(k - 1 + end)
        target = targets[k - 1] + end * (targets[k] - targets[k - 1])
        d_star = b @ tangent @ b.T
        try:
            ctl.check_block(d_star, stress)
        except _Failure as failure:
            failure.applied = report.sub_steps > 0
            raise
        de = _solve_mixed(d_star, stress, h * de_step, target - b @ reference)
        deps = b.T @ de
        specimen.apply_strain(deps)
        reference = reference + tangent @ deps
        report.sub_steps += 1
        done = end

    b = frame.matrix(k)
    target = targets[k]
    residual = np.where(stress, target - b @ specimen.stress(), 0.0)
    error = float(np.linalg.norm(residual))
    first_error = error
    report.error = _relative(error, specimen.stress(), target[stress])
    while error > ctl.allowed(specimen.stress(), target[stress]) and \
            report.iterations < ctl.max_iterations:
        d_star = b @ specimen.tangent() @ b.T
        try:
            ctl.check_block(d_star, stress)
        except _Failure as failure:
            failure.applied = True
            raise
        de = _solve_mixed(d_star, stress, np.zeros_like(residual), ctl.damping * residual)
        specimen.apply_strain(b.T @ de)
        report.iterations += 1
        residual = np.where(stress, target - b @ specimen.stress(), 0.0)
        new_error = float(np.linalg.norm(residual))
        report.error = _relative(new_error, specimen.stress(), target[stress])
        if new_error >= error:
            ctl.damping /= 2.0
            ctl.totals["halvings"] += 1
            if ctl.damping < ctl.smallest_piece:
                ctl.damping = 1.0
                raise _Failure(
                    "the stress target cannot be reached: the stress error grows after "
                    f"{ctl.max_halvings} halvings of the correction "
                    f"(error {new_error:.6g} Pa)", applied=True)
        elif new_error < 0.25 * error and ctl.damping < 1.0:
            ctl.damping = min(1.0, 2.0 * ctl.damping)
        error = new_error
    report.error = _relative(error, specimen.stress(), target[stress])
    report.converged = error <= ctl.allowed(specimen.stress(), target[stress])
    if not report.converged and error >= first_error:
        raise _Failure(
            f"the stress target cannot be reached: {report.iterations} corrections did not "
            f"reduce the stress error ({error:.6g} Pa)", applied=True)
    return report


# -- table rows ---------------------------------------------------------------------------------
def _strain_column(label: str) -> str:
    return ("eps_" if label[0] == label[1] else "gamma_") + label


def state_row(specimen: ElementSpecimen) -> dict[str, Any]:
    """Stress, strain and principal-stress columns of the specimen's current state.

    >>> class Rest:
    ...     dimension = 2
    ...     def stress(self): return np.array([3.0, 1.0, 0.0])
    ...     def strain(self): return np.zeros(3)
    >>> row = state_row(Rest())
    >>> row["sigma_1"], row["p"], row["stress_ratio"]
    (3.0, 2.0, 3.0)
    """
    dim = specimen.dimension
    sigma = np.asarray(specimen.stress(), dtype=float)
    eps = np.asarray(specimen.strain(), dtype=float)
    labels = voigt_labels(dim)
    row: dict[str, Any] = {f"sigma_{c}": float(v) for c, v in zip(labels, sigma, strict=True)}
    row.update({_strain_column(c): float(v) for c, v in zip(labels, eps, strict=True)})
    row.update(stress_invariants(voigt_to_tensor(sigma, engineering_shear=False)))
    row.update(strain_invariants(voigt_to_tensor(eps, engineering_shear=True)))
    return row


def _record(specimen: ElementSpecimen, stage: str, step: int, increment: int, angle: float,
            report: _StepReport) -> dict[str, Any]:
    row: dict[str, Any] = {"increment": increment, "stage": stage, "step": step}
    row.update(state_row(specimen))
    row.update({"frame_angle": angle, "sub_steps": report.sub_steps,
                "iterations": report.iterations, "stress_error": report.error,
                "converged": report.converged})
    for key, value in specimen.descriptors().items():
        if key in row:
            raise InputError("specimen.descriptors()", key,
                             "a descriptor name not used by the driver's columns")
        row[key] = value
    return row


# -- the driver ---------------------------------------------------------------------------------
def run_element_test(
    specimen: ElementSpecimen,
    path: LoadPath,
    progress: Callable[[int, int], None] | None = None,
    *,
    max_iterations: int = 10,
    tolerance: float = 1e-4,
    absolute_tolerance: float = 1e-9,
    max_halvings: int = 6,
    substep_threshold: float = 0.5,
    singular_tolerance: float = 1e-9,
) -> TestResult:
    """Run the load path ``path`` on ``specimen`` and return the :class:`TestResult`.

    Parameters
    ----------
    specimen:
        Any :class:`~grainlab.lab.specimen.ElementSpecimen` of the path's dimension.
    path:
        The :class:`~grainlab.lab.load_path.LoadPath` (presets in
        :mod:`grainlab.lab.load_path`).
    progress:
        Called as ``progress(steps_done, steps_total)`` after each step.
    max_iterations:
        Corrections per step at most [-].
    tolerance:
        Relative stress error accepted, times max(|sigma|, |target|) [-].
    absolute_tolerance:
        Stress error always accepted [Pa].
    max_halvings:
        Halvings of the piece size or of a correction at most [-].
    substep_threshold:
        Relative change of the tangent across a piece that halves the next piece [-].
    singular_tolerance:
        Relative eigenvalue under which D*_SS counts as singular [-].

    Returns
    -------
    TestResult
        Table as in the module docstring; ``metadata["outcome"]`` holds ``status``
        (``"completed"``/``"failure"``), for a failure ``reason``, ``stage``, ``step`` (within
        the stage) and ``increment``, and always ``steps_completed``, ``iterations_total``,
        ``iterations_max``, ``sub_steps_total``, ``halvings``, ``unconverged_steps``,
        ``unconverged_increments`` (first 50) and ``stopped`` (stop criteria that ended a stage
        or the test).

    Examples
    --------
    K0 = lambda / (lambda + 2 mu) of an elastic oedometer (lambda = mu = 1 MPa):

    >>> from grainlab.lab.presets import oedometer
    >>> class Elastic:
    ...     dimension = 3
    ...     D = 1e6 * (np.outer([1, 1, 1, 0, 0, 0], [1, 1, 1, 0, 0, 0])
    ...                + np.diag([2, 2, 2, 1, 1, 1]))
    ...     eps = np.zeros(6)
    ...     def stress(self): return self.D @ self.eps
    ...     def strain(self): return self.eps
    ...     def tangent(self): return self.D
    ...     def apply_strain(self, increment): self.eps = self.eps + increment
    ...     def descriptors(self): return {}
    ...     def describe(self): return {"kind": "elastic"}
    >>> r = run_element_test(Elastic(), oedometer(strain_final=1e-3, n_steps=2))
    >>> last = r.table.iloc[-1]
    >>> r.outcome["status"], round(float(last["sigma_xx"] / last["sigma_zz"]), 9)
    ('completed', 0.333333333)
    """
    parameters = {"max_iterations": max_iterations, "tolerance": tolerance,
                  "absolute_tolerance": absolute_tolerance, "max_halvings": max_halvings,
                  "substep_threshold": substep_threshold,
                  "singular_tolerance": singular_tolerance}
    ctl = _checked_controller(specimen, path, parameters)
    log = _RunLog(rows=[_record(specimen, "initial", 0, 0, 0.0, _StepReport())])
    _run_stages(specimen, path, ctl, progress, log)
    if log.unconverged:
        warnings.warn(
            f"{len(log.unconverged)} step(s) of {path.name!r} ended with a stress error above "
            f"the tolerance after {max_iterations} corrections (increments "
            f"{log.unconverged[:5]}...); see the 'converged' and 'stress_error' columns",
            GrainlabWarning, stacklevel=2)
    return TestResult.create(
        pd.DataFrame(log.rows), specimen=specimen.describe(), load_path=path.to_dict(),
        parameters=parameters, outcome=log.summary(ctl),
        dimension=path.dimension, title=path.name)


def _checked_controller(specimen: ElementSpecimen, path: LoadPath,
                        parameters: dict[str, Any]) -> _Controller:
    """The step controller of :func:`run_element_test`'s numerical ``parameters``, each
    checked, after checking that ``path`` is a load path of the specimen's dimension."""
    if not isinstance(path, LoadPath):
        raise InputError("path", path, "a LoadPath (see grainlab.lab.load_path presets)")
    if specimen.dimension != path.dimension:
        raise InputError("path.dimension", path.dimension,
                         f"the specimen's dimension {specimen.dimension}")
    for name in ("max_iterations", "max_halvings"):
        value = parameters[name]
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise InputError(name, value, "an integer >= 0")
    for name in ("tolerance", "absolute_tolerance", "substep_threshold", "singular_tolerance"):
        value = parameters[name]
        if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0.0):
            raise InputError(name, value, "a finite number >= 0")
    return _Controller(parameters["max_iterations"], float(parameters["tolerance"]),
                       float(parameters["absolute_tolerance"]), parameters["max_halvings"],
                       float(parameters["substep_threshold"]),
                       float(parameters["singular_tolerance"]))


@dataclass
class _RunLog:
    """What :func:`run_element_test` gathers as it goes: the table's rows, the outcome (a
    failure's), the stop criteria met, the unconverged increments, the corrections of each
    step and the sub-steps."""

    rows: list[dict[str, Any]]
    outcome: dict[str, Any] = field(default_factory=lambda: {"status": "completed"})
    stopped: list[dict[str, Any]] = field(default_factory=list)
    unconverged: list[int] = field(default_factory=list)
    iterations: list[int] = field(default_factory=lambda: [0])
    sub_steps: int = 0

    def add(self, row: dict[str, Any], report: _StepReport) -> None:
        """One step's row and its corrections and sub-steps."""
        self.iterations.append(report.iterations)
        self.sub_steps += report.sub_steps
        self.rows.append(row)

    def summary(self, ctl: _Controller) -> dict[str, Any]:
        """``metadata["outcome"]`` (:func:`run_element_test`, "Returns")."""
        return self.outcome | {
            "steps_completed": len(self.rows) - 1,
            "iterations_total": int(sum(self.iterations)),
            "iterations_max": int(max(self.iterations)),
            "sub_steps_total": self.sub_steps,
            "halvings": ctl.totals["halvings"],
            "unconverged_steps": len(self.unconverged),
            "unconverged_increments": self.unconverged[:_UNCONVERGED_LISTED],
            "stopped": self.stopped,
        }


def _run_stages(specimen: ElementSpecimen, path: LoadPath, ctl: _Controller,
                progress: Callable[[int, int], None] | None, log: _RunLog) -> None:
    """The stages of ``path`` step by step into ``log``, until the path ends, a stop
    criterion ends the test or a step fails."""
    increment = 0
    for stage in path.stages:
        frame = ControlFrame(stage)
        start = frame.matrix(0.0) @ specimen.stress()
        targets = stage.stress_targets(start)
        de_step = stage.strain_increment()
        for k in range(1, stage.n_steps + 1):
            increment += 1
            try:
                report = _advance(specimen, stage, k, targets, de_step, ctl, frame)
            except _Failure as failure:
                if failure.applied:
                    report = failure.report or _StepReport(converged=False, error=math.nan)
                    log.add(_record(specimen, stage.name, k, increment,
                                    stage.frame_angle(k), report), report)
                log.outcome = {"status": "failure", "reason": failure.reason,
                               "stage": stage.name, "step": k, "increment": increment}
                return
            if not report.converged:
                log.unconverged.append(increment)
            row = _record(specimen, stage.name, k, increment, stage.frame_angle(k), report)
            log.add(row, report)
            if progress is not None:
                progress(increment, path.n_steps)
            hit = next((c for c in stage.stop if c.met(row)), None)
            if hit is not None:
                log.stopped.append({"stage": stage.name, "increment": increment,
                                    "criterion": hit.to_dict()})
                if hit.ends == "test":
                    return
                break
