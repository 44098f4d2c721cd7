"""The 3D b-sweep of runs and models (``grainlab theory-b-sweep``): its cases, its configs
(the discrete lab's cubical and true_triaxial tests on one sample) and its refusals; the
run itself is exercised by tests/lab/test_theory_comparison.py."""

from __future__ import annotations

import math

import pytest

from grainlab.errors import InputError
from grainlab.lab.theory_b_sweep import BSweepPlan, folder_name


def test_every_path_at_every_b_on_one_sample():
    plan = BSweepPlan(b_values=(0.0, 0.5, 1.0, 0.5))
    assert plan.cases == tuple((p, b) for p in ("cubical", "true_triaxial")
                               for b in (0.0, 0.5, 1.0))
    configs = [plan.config(path, b) for path, b in plan.cases]
    assert {c.sample.seed for c in configs} == {1}  # one packing for every test
    assert {c.sample.n_particles for c in configs} == {1000}
    assert [c.test.kind for c in configs] == ["cubical"] * 3 + ["true_triaxial"] * 3
    assert [c.test.b for c in configs] == [0.0, 0.5, 1.0] * 2
    assert all(math.isclose(c.solver.shear.friction, 0.4) for c in configs)
    assert len({folder_name(p, b) for p, b in plan.cases}) == len(plan.cases)
    # the cubical test's stages hold sigma_yy and b (its control basis), after a compaction
    stages = configs[1].load_path().stages
    assert stages[0].name == "compaction" and stages[-1].component_basis is not None


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"paths": ("triaxial",)}, "--path"),
    ({"b_values": (1.5,)}, "--b"),
    ({"b_values": ()}, "--b"),
    ({"sigma0": 0.0}, "--sigma0"),
    ({"friction": -0.1}, "--mu"),
    ({"solver": "nscd"}, "--solver"),
    ({"model_steps": 0}, "--model-steps"),
    ({"distributions": ("voigt",)}, "--distribution"),
])
def test_bad_input_names_the_option(kwargs, field):
    with pytest.raises(InputError) as raised:
        BSweepPlan(**kwargs)
    assert field in raised.value.field


def test_the_command_refuses_bad_input_before_any_run(tmp_path):
    from typer.testing import CliRunner

    from grainlab.cli.main import app

    out = tmp_path / "never"
    for arguments, named in ((["--b", "2"], "--b"), (["--path", "oedometer"], "--path"),
                             (["--solver", "x"], "--solver")):
        result = CliRunner().invoke(app, ["theory-b-sweep", *arguments, "-o", str(out)])
        assert result.exit_code == 2, result.output
        assert named in result.output
        assert not out.exists()
