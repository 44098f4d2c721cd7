"""The vector force pass on plain sphere rows (:mod:`grainlab.engine.dem.sphere_rows`) against the
general row of :func:`~grainlab.engine.dem.soft_contact_kernels.contact_forces_kernel`: the same
outputs, bit for bit, on random rows that cover every case of the law."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.contact.soft_contact_law import SoftContactLaw
from grainlab.engine.dem.soft_contact_kernels import contact_forces_kernel, plain_blocks
from grainlab.engine.dem.substep_arrays import ROW_BLOCK, body_arrays, sphere_row_arrays

RADIUS = 1e-3


def random_rows(seed: int, n_rows: int = 3 * ROW_BLOCK + 37):
    """Rows between random spheres of a sheared periodic cell, each row its own pair of
    bodies (labelled at random), with images; about half closed (overlaps up to 2 % of a
    radius), the rest open within the skin; random velocities, spins and tangential
    histories (some zero); the last row with coincident centres."""
    rng = np.random.default_rng(seed)
    n_bodies = 2 * n_rows
    cell_h = np.array([[0.02, 0.003, 0.0], [0.0, 0.021, 0.001], [0.0, 0.0, 0.019]])
    cell_rate = rng.normal(0.0, 0.05, (3, 3)) * 1e-3
    labels = rng.permutation(n_bodies)
    body_i, body_j = labels[:n_rows], labels[n_rows:]
    images = rng.integers(-1, 2, (n_rows, 3)).astype(np.float64)
    images[rng.random(n_rows) < 0.6] = 0.0
    rad_i = RADIUS * rng.uniform(0.5, 1.0, n_rows)
    rad_j = RADIUS * rng.uniform(0.5, 1.0, n_rows)
    direction = rng.normal(size=(n_rows, 3))
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    gap = np.where(rng.random(n_rows) < 0.5, -0.02, 0.1) * RADIUS * rng.random(n_rows)
    positions = np.empty((n_bodies, 3))
    positions[body_i] = rng.uniform(0.0, 0.02, (n_rows, 3))
    # j's image at the chosen gap from i
    positions[body_j] = positions[body_i] + (rad_i + rad_j + gap)[:, None] * direction \
        - images @ cell_h.T
    body_j[-1], images[-1] = body_i[-1], 0.0  # coincident centres (a degenerate row)
    velocities = rng.normal(0.0, 0.01, (n_bodies, 3))
    spins = rng.normal(0.0, 5.0, (n_bodies, 3))
    xi = rng.normal(0.0, 1e-2, (n_rows, 3)) * (rng.random(n_rows) < 0.7)[:, None]
    mu = np.full(n_rows, 0.4)
    inv_mass = 1.0 / rng.uniform(1e-6, 3e-6, n_bodies)
    return dict(body_i=body_i, body_j=body_j, images=images, rad_i=rad_i, rad_j=rad_j,
                positions=positions, velocities=velocities, spins=spins, xi=xi, mu=mu,
                inv_mass=inv_mass, cell_h=cell_h, cell_rate=cell_rate)


def evaluate(rows, law, step, record, vector):
    """All outputs of one force pass over ``rows``, through the vector blocks or not."""
    c = rows["body_j"].shape[0]
    xi, roll = rows["xi"].copy(), np.zeros((c, 3))
    out = {"force": np.zeros((c, 3)), "torque_i": np.zeros((c, 3)),
           "torque_j": np.zeros((c, 3)), "gap": np.zeros(c), "normal": np.zeros((c, 3)),
           "point": np.zeros((c, 3)), "stiffness": np.full(c, -1.0),
           "rel_vel": np.zeros((c, 3)), "virial": np.zeros((3, 3))}
    stats = np.zeros(1)
    zeros = np.zeros((c, 3))
    plain = plain_blocks(rows["body_i"], zeros, zeros)
    assert plain.all()
    arrays = sphere_row_arrays(rows["body_i"], rows["body_j"], rows["rad_i"], rows["rad_j"],
                               images=rows["images"], mu=rows["mu"], xi=xi, roll=roll,
                               plain=plain & vector, **{k: v for k, v in out.items()
                                                        if k != "virial"})
    bodies = body_arrays(rows["positions"], rows["velocities"], rows["spins"],
                         rows["inv_mass"])
    contact_forces_kernel(step, record, law.code, law.params, 0.0, arrays, bodies,
                          np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0),
                          rows["cell_h"], rows["cell_rate"], out["virial"], stats)
    out["xi"], out["stats"] = xi, stats
    return out


LAWS = {"hertz_mindlin": SoftContactLaw.hertz_mindlin(1e9, 0.25, 0.5),
        "linear": SoftContactLaw.linear(1e5, 0.5, 0.5)}


@pytest.mark.parametrize("model", sorted(LAWS))
@pytest.mark.parametrize("step", [0.0, 1e-7])
def test_vector_rows_give_the_general_rows_bits(model, step):
    rows = random_rows(seed=7 + int(step > 0.0))
    general = evaluate(rows, LAWS[model], step, True, vector=False)
    vector = evaluate(rows, LAWS[model], step, True, vector=True)
    closed = general["gap"] < 0.0
    assert 0.3 < closed.mean() < 0.7  # both kinds of row are there
    loaded = np.linalg.norm(general["force"][closed], axis=1) > 0.0
    assert loaded.mean() > 0.8  # (a fast-opening row's dashpot may cancel its force)
    for name in ("gap", "force", "torque_i", "torque_j", "xi", "stiffness", "virial", "stats"):
        assert np.array_equal(vector[name], general[name]), name
    for name in ("normal", "point", "rel_vel"):  # the general row writes them if closed
        assert np.array_equal(vector[name][closed], general[name][closed]), name
    # open rows come out released: no force, no history
    assert not np.any(vector["force"][~closed]) and not np.any(vector["xi"][~closed])


def test_vector_rows_slide_and_stick_as_coulomb_says():
    """Some closed rows are at the Coulomb limit (|f_t| = mu f_n, to round-off), others
    below it: both branches of the projection are taken, and never above it."""
    law = LAWS["linear"]
    rows = random_rows(seed=11)
    rows["xi"] *= 50.0  # large springs: many rows slide
    out = evaluate(rows, law, 1e-7, False, vector=True)
    closed = out["gap"] < 0.0
    f = out["force"][closed]
    normal = rows["positions"][rows["body_j"]] + rows["images"] @ rows["cell_h"].T \
        - rows["positions"][rows["body_i"]]
    normal = normal[closed][:-1] / np.linalg.norm(normal[closed][:-1], axis=1)[:, None]
    f = f[:-1]  # the coincident row: normal (0, 0, 1)
    f_n = np.einsum("ki,ki->k", f, normal)
    f_t = np.linalg.norm(f - f_n[:, None] * normal, axis=1)
    ratio = f_t[f_n > 0.0] / f_n[f_n > 0.0]
    assert np.all(ratio <= 0.4 * (1.0 + 1e-12))
    assert np.any(ratio > 0.4 * (1.0 - 1e-12)) and np.any(ratio < 0.3)


def test_blocks_with_a_wall_or_an_aggregate_member_are_not_plain():
    c = 2 * ROW_BLOCK + 5
    body_i = np.zeros(c, dtype=np.int64)
    off = np.zeros((c, 3))
    assert plain_blocks(body_i, off, off).tolist() == [True, True, True]
    body_i[ROW_BLOCK + 3] = -1  # a wall row in block 1
    off_j = off.copy()
    off_j[-1, 2] = 1e-4  # an aggregate member in the last block
    assert plain_blocks(body_i, off, off_j).tolist() == [True, False, False]

