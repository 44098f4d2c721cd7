"""Progress bars that show in a terminal and in a Jupyter notebook.

In a terminal a :class:`rich.progress.Progress` redraws itself in place (rich's live
display). In a notebook rich's live display needs ipywidgets, and a widget's state is not
kept when the notebook is saved or executed by a documentation build; here the bar is instead
an ordinary output of the cell, replaced in place at most every ``refresh_seconds`` through an
IPython display handle, so that it shows in JupyterLab, VS Code and an executed notebook
alike, and its last state stays in the saved notebook."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

NOTEBOOK_COLUMNS = 200
"""Characters per line of the bar in a notebook: a run's bar carries a long line of numbers,
which a notebook's default width (rich's 115) would cut, squeezing the bar out."""


class NotebookBar:
    """The bar's state as a notebook output: HTML (a ``<pre>`` of the bar drawn by rich at
    :data:`NOTEBOOK_COLUMNS` characters, colours inline) and plain text, and the renderable
    itself for a rich console."""

    def __init__(self, renderable) -> None:
        self.renderable = renderable

    def _draw(self):
        import io

        from rich.console import Console

        console = Console(file=io.StringIO(), width=NOTEBOOK_COLUMNS, record=True,
                          force_terminal=True, force_jupyter=False, color_system="truecolor")
        console.print(self.renderable)
        return console

    def _repr_html_(self) -> str:
        return self._draw().export_html(inline_styles=True, code_format=(
            '<pre style="white-space: pre; overflow-x: auto; font-size: 0.8em">{code}</pre>'))

    def __repr__(self) -> str:
        return self._draw().export_text().rstrip()

    def __rich__(self):
        return self.renderable


class LiveProgress:
    """A rich progress bar (its columns as given) that shows wherever the code runs.

    Parameters
    ----------
    columns:
        The :mod:`rich.progress` columns of the bar.
    notebook:
        Draw it as a notebook output (True), as a terminal's live display (False), or as the
        console finds (None: rich's own test for a Jupyter kernel).
    display:
        The notebook's display function (``IPython.display.display`` when None), called as
        ``display(renderable, display_id=True)`` and returning a handle with ``update``.
    refresh_seconds:
        Shortest time between two redraws in a notebook, in s.
    """

    def __init__(self, *columns: Any, notebook: bool | None = None,
                 display: Callable[..., Any] | None = None,
                 refresh_seconds: float = 0.5) -> None:
        from rich.console import Console
        from rich.progress import Progress

        console = Console()
        self.notebook = console.is_jupyter if notebook is None else notebook
        self.progress = Progress(*columns, console=console, disable=self.notebook)
        self._display = display
        self._handle = None
        self._drawn = -float("inf")
        self.refresh_seconds = refresh_seconds

    @property
    def console(self):
        return self.progress.console

    @property
    def tasks(self):
        return self.progress.tasks

    @property
    def columns(self):
        return self.progress.columns

    def add_task(self, description: str, **fields: Any):
        return self.progress.add_task(description, **fields)

    def update(self, task, **fields: Any) -> None:
        self.progress.update(task, **fields)
        self._redraw(force=False)

    def reset(self, task, **fields: Any) -> None:
        self.progress.reset(task, **fields)

    def table(self) -> NotebookBar:
        """The bar as a notebook output: one row per task, the columns as given."""
        return NotebookBar(self.progress.make_tasks_table(self.progress.tasks))

    def start(self) -> None:
        if not self.notebook:
            self.progress.start()
            return
        display = self._display
        if display is None:
            from IPython.display import display
        self._handle = display(self.table(), display_id=True)
        self._drawn = time.monotonic()

    def _redraw(self, force: bool) -> None:
        if self._handle is None:
            return
        now = time.monotonic()
        if force or now - self._drawn >= self.refresh_seconds:
            self._handle.update(self.table())
            self._drawn = now

    def stop(self) -> None:
        if self.notebook:
            self._redraw(force=True)
            self._handle = None
        else:
            self.progress.stop()
