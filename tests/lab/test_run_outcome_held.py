"""Every loading stage judges the stresses it holds and its unconverged steps, for both
solvers and both boundaries, in one place (:func:`grainlab.lab.run_outcome.stage_outcome`).

The records are those of two runs that exited 0 with a wrong answer (the runs themselves take
minutes; their records, as measured, are judged here):

* a one-step simple shear of 200 rigid spheres in a periodic cell (``grainlab test
  simple_shear --boundary periodic -n 200 --gamma 1e-9``): the step did not converge and the
  cell's sigma_zz went from 1e4 to 3.4e6 Pa (the contacts' to 8.4e7);
* a 100-sphere wall-box triaxial test with walls of momentum (``wall_servo = false``,
  ``wall_mass_factor = 1e-6``): 6 records of its loading, lateral stresses between 4.3 and
  13.7 kPa around 10 kPa, 34 of its 60 steps at the sweep cap.
"""

from __future__ import annotations

import pytest

from grainlab.lab.discrete_test import DiscreteTestSettings
from grainlab.lab.run_outcome import (
    HELD_STRESS_ERROR,
    HELD_STRESS_WORST,
    RunOutcome,
    StageOutcome,
    stage_outcome,
)
from grainlab.lab.stage_numerics import SHEAR

SIGMA0 = 1e4
CASE_2_LATERAL = [(12620.742176, 12601.735897), (8187.577997, 7994.417414),
                  (11222.469469, 11228.405990), (12006.486508, 9971.380458),
                  (12037.743082, 13721.453565), (5251.107843, 4311.690592)]
"""sigma_xx, sigma_yy [Pa] of the walls at the 6 records of the 100-sphere loading."""


def _record(steps: int, capped: int) -> dict:
    return {"name": "shear", "reason": "strain reached", "steps": steps, "ended": "reached",
            "capped_steps": capped, "strain_controlled": True}


def _judge(method: str, rows: list[dict], targets: dict, steps: int = 60,
           capped: int = 0) -> StageOutcome:
    settings = DiscreteTestSettings(method=method)
    return stage_outcome(_record(steps, capped), rows, settings, targets)


def _rows(columns: tuple[str, ...], values) -> list[dict]:
    return [{"stage": "shear", "inertia_number": 5e-4, "z": 4.5,
             **dict(zip(columns, v, strict=True))} for v in values]


@pytest.mark.parametrize("method", ["cd", "dem"])
def test_a_stress_off_by_orders_of_magnitude_in_one_step_is_not_as_asked(method):
    rows = _rows(("cell_sigma_zz",), [(3.425443e6,)])
    stage = _judge(method, rows, {"zz": SIGMA0}, steps=1)
    assert dict(stage.stress_worst)["zz"] == pytest.approx(3.425443e6 / SIGMA0 - 1.0)
    outcome = RunOutcome(stages=(stage,), finished=True, steps=1)
    assert not outcome.as_asked
    assert any("sigma_zz left its target" in p for p in outcome.problems())
    # the same step on its target: held (the check can pass)
    held = _judge(method, _rows(("cell_sigma_zz",), [(1.02e4,)]), {"zz": SIGMA0}, steps=1)
    assert held.problems() == []


@pytest.mark.parametrize("method", ["cd", "dem"])
def test_lateral_stresses_swinging_around_their_target_are_not_as_asked(method):
    rows = _rows(("wall_sigma_xx", "wall_sigma_yy"), CASE_2_LATERAL)
    stage = _judge(method, rows, {"xx": SIGMA0, "yy": SIGMA0})
    medians = dict(stage.stress_errors)
    assert medians["xx"] == pytest.approx(0.2022, abs=1e-4)  # median |sigma / target - 1|
    assert medians["yy"] == pytest.approx(0.2304, abs=1e-4)
    assert max(dict(stage.stress_worst).values()) == pytest.approx(0.5688, abs=1e-4)
    assert all(m > HELD_STRESS_ERROR for m in medians.values())
    assert max(dict(stage.stress_worst).values()) < HELD_STRESS_WORST  # the median sees it
    assert sum("did not hold sigma_" in p for p in stage.problems()) == 2
    # the same records a tenth as far from the target: held
    near = [(SIGMA0 + 0.1 * (x - SIGMA0), SIGMA0 + 0.1 * (y - SIGMA0)) for x, y in CASE_2_LATERAL]
    held = _judge(method, _rows(("wall_sigma_xx", "wall_sigma_yy"), near),
                  {"xx": SIGMA0, "yy": SIGMA0})
    assert held.problems() == []


def test_more_than_half_the_loading_steps_unconverged_is_not_as_asked():
    """34 of 60 contact-dynamics steps at the cap: above the loading's default limit."""
    assert SHEAR.capped_share_limit == 0.5
    rows = _rows(("wall_sigma_xx",), [(SIGMA0,)] * 6)
    capped = _judge("cd", rows, {"xx": SIGMA0}, capped=34)
    assert capped.capped_share == pytest.approx(34 / 60)
    assert any("34 of 60 steps" in p and "solver.shear.capped_share_limit" in p
               for p in capped.problems())
    assert _judge("cd", rows, {"xx": SIGMA0}, capped=30).problems() == []  # half: accepted


def test_a_stage_judged_keeps_its_worst_stress_through_plain_data():
    rows = _rows(("wall_sigma_xx",), [(SIGMA0 * 3.0,)])
    stage = _judge("cd", rows, {"xx": SIGMA0}, steps=1)
    again = StageOutcome.from_dict(stage.to_dict())
    assert again == stage and again.problems() == stage.problems() != []


def test_a_true_triaxial_stage_judges_its_generalised_stresses():
    """Constant p and b are held as components of c = B sigma (sqrt(3) p, and 0 along the
    deviator's direction that b fixes): judged like the normal stresses, against sqrt(3) p."""
    from grainlab.lab.cell_boundary import generalised_targets
    from grainlab.lab.cell_stages import cell_stages
    from grainlab.lab.run_config import RunConfig

    config = RunConfig.model_validate({"sample": {"boundary": "periodic"},
                                       "test": {"kind": "true_triaxial", "b": 0.3}})
    stage = cell_stages(config.load_path())[1]
    targets = generalised_targets(stage)
    first = next(iter(targets.values()))
    assert first[0] == pytest.approx(3.0 ** 0.5 * SIGMA0, rel=1e-12)  # sqrt(3) p
    b = stage.control(0.0)

    def rows(p: float) -> list[dict]:
        # principal stresses at b = 0.3 about p: z major, x intermediate, y minor
        s1, s3 = p + 0.4 * p, p - 0.4 * p
        s2 = s3 + 0.3 * (s1 - s3)
        shift = (3 * p - (s1 + s2 + s3)) / 3.0
        sigma = {"cell_sigma_xx": s2 + shift, "cell_sigma_yy": s3 + shift,
                 "cell_sigma_zz": s1 + shift, "cell_sigma_yz": 0.0, "cell_sigma_xz": 0.0,
                 "cell_sigma_xy": 0.0}
        return [{"stage": "shear", "inertia_number": 5e-4, "z": 4.5, **sigma}] * 10

    held = _judge("cd", rows(SIGMA0), targets)
    voigt = [rows(SIGMA0)[0][f"cell_sigma_{a}"] for a in ("xx", "yy", "zz", "yz", "xz", "xy")]
    assert abs(float(b[2] @ voigt)) < 1e-8 * SIGMA0  # the deviator's direction of b = 0.3
    assert held.problems() == []
    low = _judge("cd", rows(0.7 * SIGMA0), targets)
    assert any("did not hold (B sigma)_2" in p for p in low.problems())
