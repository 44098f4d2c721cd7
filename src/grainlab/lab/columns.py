"""Standard column names of test-result tables, with their units and meaning.

Stresses are Cauchy stresses averaged over the specimen, compression positive [Pa]; strains are
small (or logarithmic, where stated) strains, compression positive [-]; ``gamma_xy`` is the
engineering shear strain 2 eps_xy. Columns a specimen cannot provide are simply absent.
"""

from __future__ import annotations

STANDARD_COLUMNS: dict[str, tuple[str, str]] = {
    "increment": ("-", "index of the recorded increment"),
    "stage": ("-", "name of the loading stage"),
    "sigma_xx": ("Pa", "normal stress on x faces"),
    "sigma_yy": ("Pa", "normal stress on y faces"),
    "sigma_zz": ("Pa", "normal stress on z faces"),
    "sigma_xy": ("Pa", "shear stress xy (symmetric part)"),
    "sigma_xz": ("Pa", "shear stress xz (symmetric part)"),
    "sigma_yz": ("Pa", "shear stress yz (symmetric part)"),
    "sigma_1": ("Pa", "major principal stress"),
    "sigma_2": ("Pa", "intermediate principal stress"),
    "sigma_3": ("Pa", "minor principal stress"),
    "p": ("Pa", "mean stress (sigma_1 + sigma_3)/2 in 2D, trace/3 in 3D"),
    "q": ("Pa", "deviator sigma_1 - sigma_3"),
    "q_over_3": ("Pa", "deviator (sigma_1 - sigma_3)/3 as used in seeds 002/003"),
    "stress_ratio": ("-", "principal stress ratio sigma_1/sigma_3"),
    "K0": ("-", "lateral stress ratio (sigma_xx + sigma_yy)/(2 sigma_zz) of 1-D compression"),
    "eps_xx": ("-", "normal strain xx"),
    "eps_yy": ("-", "normal strain yy"),
    "eps_zz": ("-", "normal strain zz"),
    "gamma_xy": ("-", "engineering shear strain 2 eps_xy"),
    "gamma_xz": ("-", "engineering shear strain 2 eps_xz"),
    "gamma_yz": ("-", "engineering shear strain 2 eps_yz"),
    "eps_vol": ("-", "volumetric strain"),
    "void_ratio": ("-", "void ratio"),
}


def unit_of(column: str) -> str:
    """Unit of a standard column, or ``""`` for a column grainlab does not know."""
    return STANDARD_COLUMNS.get(column, ("", ""))[0]
