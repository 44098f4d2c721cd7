"""Every figure function of the report layer hands back its matplotlib Figure, so that a user
can restyle it, show it in a notebook or save it anywhere."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import grainlab.report


def _figure_functions():
    for info in pkgutil.iter_modules(grainlab.report.__path__):
        module = importlib.import_module(f"grainlab.report.{info.name}")
        for name, function in inspect.getmembers(module, inspect.isfunction):
            if function.__module__ == module.__name__ and name.endswith("_figure") \
                    and not name.startswith("_") and name != "save_figure":
                yield f"{info.name}.{name}", function


def test_every_figure_function_is_declared_to_return_a_figure():
    found = dict(_figure_functions())
    assert len(found) > 30
    wrong = {name: inspect.signature(f).return_annotation for name, f in found.items()
             if "Figure" not in str(inspect.signature(f).return_annotation)}
    assert not wrong


def test_a_figure_comes_back_restylable():
    import matplotlib
    import numpy as np
    import pandas as pd

    from grainlab.report.microstructure_figures import anisotropy_evolution_figure

    matplotlib.use("Agg")
    eps = np.linspace(0.0, 0.3, 7)
    table = pd.DataFrame({"eps_q": eps, "a_c": 0.2 * eps, "a_n": 0.3 * eps, "a_t": 0.1 * eps,
                          "a_l": 0.05 * eps, "q_over_trace": 0.3 * np.ones_like(eps)})
    figure = anisotropy_evolution_figure(table)
    assert isinstance(figure, matplotlib.figure.Figure)
    figure.axes[0].set_title("restyled")
    assert figure.axes[0].get_title() == "restyled"
