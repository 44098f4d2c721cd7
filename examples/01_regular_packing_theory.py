"""Seed 000 in a few lines: packing C of Chang, Misra & Xue (1989) loaded at alpha = 45 deg.

Run:  .venv/bin/python examples/01_regular_packing_theory.py [OUTPUT_FOLDER]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import grainlab as gl
from grainlab.contact import ModifiedHertzMindlin2D
from grainlab.micromech import RegularPackingModel, RotatedStressPath, run_rotated_stress_path
from grainlab.report import contact_force_figure, save_figure, stress_ratio_strain_figure


def main(out: Path) -> gl.TestResult:
    packing = gl.named_packing("C")  # discs 2:1, e = 0.1388, CN = 5 (Table 1)
    model = RegularPackingModel(packing, ModifiedHertzMindlin2D.seed000())
    path = RotatedStressPath(alpha=np.radians(45.0), max_ratio=3.0)
    result = run_rotated_stress_path(model, path)
    last = result.table.iloc[-1]
    print(f"packing C: e = {packing.void_ratio:.4f}, {model.n_contacts} contacts per cell")
    print(f"at sigma_1/sigma_3 = {last.stress_ratio:.2f}: eps_x = {last.eps_xx:.3e}, "
          f"eps_y = {last.eps_yy:.3e}, gamma_xy = {last.gamma_xy:.3e}, "
          f"non-coaxiality = {last.noncoaxiality_deg:.2f} deg")
    result.save(out)
    save_figure(stress_ratio_strain_figure(result), out / "fig7.png")
    save_figure(contact_force_figure(model, result), out / "fig10.png")
    return result


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("example-01"))
