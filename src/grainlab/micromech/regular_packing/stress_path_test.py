"""Driving a regular packing along a stress path, increment by increment (seed 000 §Examples).

Each increment is solved for equilibrium with the applied average stress: Newton iterations on
the uniform strain increment, the contact forces integrated along it by the contact law from the
converged state of the previous increment, so contact forces and stiffness are updated after
every increment. The isotropic start is itself reached by loading from zero, which is what puts
shear forces on the contacts of an anisotropic packing under isotropic stress (seed 000 Fig. 10a).

The test ends at ``max_ratio`` or at failure: when no strain increment can carry the next stress
increment, even after halving it ten times (the packing's strength is reached: its contacts
slide or open), or when the stiffness D stops being positive definite.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd

from grainlab.contact.coulomb import friction_mobilisation
from grainlab.errors import ConvergenceError
from grainlab.micromech.regular_packing.model import RegularPackingModel, RegularPackingState
from grainlab.micromech.regular_packing.stress_path import RotatedStressPath
from grainlab.result.invariants import strain_invariants, stress_invariants
from grainlab.result.test_result import TestResult

RELATIVE_STRESS_TOLERANCE = 1e-10
"""Equilibrium is reached when |sigma_target - sigma(f)| <= tol |sigma_target|."""

MAX_ITERATIONS = 40
STEP_HALVINGS = 10
ISOTROPIC_STEPS = 10


def voigt_tensor(voigt: np.ndarray, shear_factor: float) -> np.ndarray:
    """(2, 2) tensor of a Voigt vector (xx, yy, xy), the shear times ``shear_factor`` (0.5
    for engineering shear strains)."""
    shear = shear_factor * voigt[2]
    return np.array([[voigt[0], shear], [shear, voigt[1]]])


def solve_stress_target(
    model: RegularPackingModel,
    start: RegularPackingState,
    target: np.ndarray,
    force_floor: float = 0.0,
    tolerance: float = RELATIVE_STRESS_TOLERANCE,
    max_iterations: int = MAX_ITERATIONS,
) -> tuple[RegularPackingState, int]:
    """Find the uniform strain increment that brings the average stress to ``target`` [Pa].

    Returns the new state and the number of Newton iterations.

    Raises
    ------
    ConvergenceError
        No equilibrium within ``max_iterations`` (the residual reached is in the message).
    """
    target = np.asarray(target, dtype=float)
    scale = max(float(np.linalg.norm(target)), np.finfo(float).tiny)
    increment = np.zeros(3)
    state = start
    residual = target - model.stress(state)
    for iteration in range(max_iterations + 1):
        if np.linalg.norm(residual) <= tolerance * scale:
            return state, iteration
        tangent = model.solver_stiffness(state, force_floor)
        try:
            step = np.linalg.solve(tangent, residual)
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(step)):
            break
        increment = increment + step
        state = model.update(start, increment)
        residual = target - model.stress(state)
    raise ConvergenceError(
        f"No equilibrium with the stress {target.tolist()} Pa: residual "
        f"{np.linalg.norm(residual) / scale:.3g} of the stress after {max_iterations} iterations."
    )


def consolidate_isotropically(
    model: RegularPackingModel, pressure: float, steps: int = ISOTROPIC_STEPS
) -> RegularPackingState:
    """Load the packing from zero to the isotropic stress ``pressure`` [Pa] in ``steps``
    equal increments; return the consolidated state (strain from the unloaded state)."""
    mean_diameter = 2.0 * float(np.mean(model.packing.radii))
    floor = 1e-2 * pressure * mean_diameter / steps
    state = model.unloaded_state()
    for k in range(1, steps + 1):
        target = np.array([1.0, 1.0, 0.0]) * pressure * k / steps
        try:
            state, _ = solve_stress_target(model, state, target, force_floor=floor)
        except ConvergenceError as error:
            raise ConvergenceError(
                f"Packing {model.packing.name!r} cannot carry an isotropic stress of "
                f"{target[0]:.6g} Pa with this contact law: under uniform strain some contacts "
                "would need more friction than tan(phi_mu) allows, or would open "
                f"({error}). Raise the friction angle or use a packing that is stable under "
                "isotropic stress."
            ) from None
    return state


def _principal_angle_from_y(xx: float, yy: float, xy: float) -> float:
    """Angle [deg] of the major principal direction of [[xx, xy], [xy, yy]] from the Y axis,
    counter-clockwise, in (-90, 90]."""
    theta = 0.5 * np.degrees(np.arctan2(2.0 * xy, xx - yy))  # from +X, counter-clockwise
    return _wrap_half_turn(theta - 90.0)


def _wrap_half_turn(angle: float) -> float:
    """Map an axis angle [deg] into (-90, 90]."""
    wrapped = (angle + 90.0) % 180.0 - 90.0
    return 90.0 if wrapped == -90.0 else wrapped


class _Recorder:
    """Collects one table row and the snapshot arrays per recorded increment."""

    def __init__(self, model: RegularPackingModel):
        self.model = model
        self.rows: list[dict] = []
        self.snapshots: dict[str, list[np.ndarray]] = {
            "normal_force": [], "tangential_force": [], "stiffness": [],
            "particle_force_residual": [], "particle_moment_residual": [],
        }

    def record(
        self, stage: str, ratio: float, state: RegularPackingState, reference: np.ndarray,
        previous: np.ndarray | None, iterations: int,
    ) -> None:
        model = self.model
        stress = model.stress(state)
        skew = model.stress_tensor(state)
        strain = state.strain - reference
        d_strain = None if previous is None else state.strain - previous
        stiffness = model.stiffness_matrix(state)
        force_res, moment_res = model.particle_residuals(state)
        contacts = state.contacts
        mean_force = float(np.mean(np.hypot(contacts.normal_force, contacts.tangential_force)))
        mean_radius = float(np.mean(model.packing.radii))
        alpha_sigma = _principal_angle_from_y(*stress)
        if d_strain is None or np.allclose(d_strain, 0.0):
            alpha_de, noncoaxiality = np.nan, np.nan
        else:
            alpha_de = _principal_angle_from_y(d_strain[0], d_strain[1], 0.5 * d_strain[2])
            noncoaxiality = _wrap_half_turn(alpha_de - alpha_sigma)
        with np.errstate(divide="ignore", invalid="ignore"):
            gamma_over_ex = strain[2] / strain[0] if strain[0] != 0 else np.nan
            ex_over_ey = strain[0] / strain[1] if strain[1] != 0 else np.nan
        self.rows.append({
            "increment": len(self.rows),
            "stage": stage,
            "sigma_xx": stress[0], "sigma_yy": stress[1], "sigma_xy": stress[2],
            **stress_invariants(voigt_tensor(stress, 1.0)),
            # the applied sigma_1/sigma_3 (equal to the measured one within the equilibrium
            # tolerance), exact so that runs can be compared at given ratios
            "stress_ratio": ratio,
            "eps_xx": strain[0], "eps_yy": strain[1], "gamma_xy": strain[2],
            **strain_invariants(voigt_tensor(strain, 0.5)),
            "gamma_xy_over_eps_xx": gamma_over_ex,
            "eps_xx_over_eps_yy": ex_over_ey,
            "stress_direction_deg": alpha_sigma,
            "strain_increment_direction_deg": alpha_de,
            "noncoaxiality_deg": noncoaxiality,
            "stress_skew": 0.5 * (skew[0, 1] - skew[1, 0]),
            "n_sliding": int(np.count_nonzero(contacts.sliding)),
            "n_open": int(np.count_nonzero(contacts.open)),
            "max_friction_mobilisation": float(np.max(friction_mobilisation(
                contacts.normal_force, contacts.tangential_force,
                model.law.friction_coefficient))),
            "D11": stiffness[0, 0], "D22": stiffness[1, 1], "D33": stiffness[2, 2],
            "D12": stiffness[0, 1], "D13": stiffness[0, 2], "D23": stiffness[1, 2],
            "min_eigenvalue_D": float(np.linalg.eigvalsh(stiffness)[0]),
            "max_force_residual": float(np.max(np.linalg.norm(force_res, axis=1)) / mean_force),
            "max_moment_residual": float(np.max(np.abs(moment_res)) / (mean_force * mean_radius)),
            "iterations": iterations,
        })
        self.snapshots["normal_force"].append(contacts.normal_force.copy())
        self.snapshots["tangential_force"].append(contacts.tangential_force.copy())
        self.snapshots["stiffness"].append(stiffness)
        self.snapshots["particle_force_residual"].append(force_res)
        self.snapshots["particle_moment_residual"].append(moment_res)

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: np.array(v) for k, v in self.snapshots.items()}


COLUMN_UNITS = {
    "gamma_xy_over_eps_xx": "-", "eps_xx_over_eps_yy": "-",
    "stress_direction_deg": "deg", "strain_increment_direction_deg": "deg",
    "noncoaxiality_deg": "deg", "stress_skew": "Pa", "n_sliding": "-", "n_open": "-",
    "max_friction_mobilisation": "-", "D11": "Pa", "D22": "Pa", "D33": "Pa", "D12": "Pa",
    "D13": "Pa", "D23": "Pa", "min_eigenvalue_D": "Pa",
    "max_force_residual": "mean contact force", "max_moment_residual": "mean force x radius",
    "iterations": "-",
}
SNAPSHOT_UNITS = {
    "normal_force": "N/m", "tangential_force": "N/m", "stiffness": "Pa",
    "particle_force_residual": "N/m", "particle_moment_residual": "N",
}


def run_rotated_stress_path(
    model: RegularPackingModel,
    path: RotatedStressPath,
    progress: Callable[[float], None] | None = None,
) -> TestResult:
    """Run seed 000's test: isotropic loading to sigma_0, then the rotated stress path.

    The table has one row per converged increment of the shear stage (row 0 is the isotropic
    state); strains are measured from the isotropic state, as in seed 000 Fig. 7. Snapshots hold
    every contact force (ordered as ``model.contacts``), the stiffness D and the particle
    residuals. ``progress`` is called with the fraction of ``max_ratio`` reached.
    """
    iso = consolidate_isotropically(model, path.confining_stress)
    start = iso
    recorder = _Recorder(model)
    reference = start.strain.copy()
    recorder.record("isotropic", 1.0, start, reference, None, 0)
    ratio, step, state = 1.0, path.ratio_step, start
    minimum_step = path.ratio_step / 2**STEP_HALVINGS
    outcome = {"status": "completed", "reason": f"reached the stress ratio {path.max_ratio:g}"}
    while ratio < path.max_ratio * (1 - 1e-12):
        trial_ratio = min(ratio + step, path.max_ratio)
        try:
            new_state, iterations = solve_stress_target(model, state, path.stress(trial_ratio))
        except ConvergenceError as error:
            step /= 2.0
            if step < minimum_step:
                contacts = state.contacts
                smallest = np.linalg.eigvalsh(model.stiffness_matrix(state))[0]
                mobilised = friction_mobilisation(
                    contacts.normal_force, contacts.tangential_force,
                    model.law.friction_coefficient,
                )
                outcome = {
                    "status": "failure",
                    "reason": (
                        f"no equilibrium beyond the stress ratio {ratio:.6g}: of "
                        f"{model.n_contacts} contacts, {int(np.count_nonzero(mobilised > 0.99))}"
                        f" have mobilised over 99 % of their friction, "
                        f"{int(np.count_nonzero(contacts.sliding))} slide and "
                        f"{int(np.count_nonzero(contacts.open))} are open; the smallest "
                        f"eigenvalue of D fell to {smallest:.3g} Pa "
                        f"({error})"
                    ),
                    "failure_stress_ratio": ratio,
                }
                break
            continue
        stiffness = model.stiffness_matrix(new_state)
        if np.linalg.eigvalsh(stiffness)[0] <= 1e-12 * np.abs(stiffness).max():
            outcome = {
                "status": "failure",
                "reason": (
                    f"the stiffness D lost positive definiteness at the ratio {trial_ratio:.6g}"
                ),
                "failure_stress_ratio": trial_ratio,
            }
            recorder.record("shear", trial_ratio, new_state, reference, state.strain, iterations)
            break
        recorder.record("shear", trial_ratio, new_state, reference, state.strain, iterations)
        ratio, state = trial_ratio, new_state
        step = min(2.0 * step, path.ratio_step) if step < path.ratio_step else step
        if progress is not None:
            progress((ratio - 1.0) / (path.max_ratio - 1.0))
    table = pd.DataFrame(recorder.rows)
    return TestResult.create(
        table,
        specimen=model.describe(),
        load_path=path.describe(),
        parameters={
            "relative_stress_tolerance": RELATIVE_STRESS_TOLERANCE,
            "isotropic_loading_steps": ISOTROPIC_STEPS,
            "isotropic_strain_voigt": iso.strain.tolist(),
            "contact_order": {
                "particle_i": model.contacts.particle_i.tolist(),
                "particle_j": model.contacts.particle_j.tolist(),
                "image": model.contacts.image.tolist(),
            },
        },
        outcome=outcome,
        units=COLUMN_UNITS,
        snapshots=recorder.arrays(),
        snapshot_units=SNAPSHOT_UNITS,
        dimension=2,
        title=f"packing {model.packing.name}, alpha = {np.degrees(path.alpha):g} deg",
    )
