"""The progress bar that shows in a terminal and in a notebook (grainlab._live_progress)."""

from __future__ import annotations

import io

from rich.progress import BarColumn, TextColumn

from grainlab._live_progress import LiveProgress


class _Handle:
    def __init__(self) -> None:
        self.shown = []

    def __call__(self, renderable, display_id=False):
        assert display_id is True
        self.shown.append(renderable)
        return self

    def update(self, renderable) -> None:
        self.shown.append(renderable)


def _text(shown) -> str:
    return repr(shown)  # the bar as plain text (NotebookBar)


def _bar(**options) -> LiveProgress:
    return LiveProgress(TextColumn("{task.description}"), BarColumn(),
                        TextColumn("{task.completed:.0f} of {task.total:.0f}"), **options)


def test_in_a_notebook_each_redraw_replaces_the_one_output_and_the_last_state_stays():
    shown = _Handle()
    bar = _bar(notebook=True, display=shown, refresh_seconds=0.0)
    task = bar.add_task("sample S1", total=10)
    bar.start()
    for done in range(1, 11):
        bar.update(task, completed=done)
    bar.stop()
    assert len(shown.shown) == 1 + 10 + 1  # the first draw, each update, the last state
    assert "0 of 10" in _text(shown.shown[0])
    assert "sample S1" in _text(shown.shown[-1]) and "10 of 10" in _text(shown.shown[-1])
    assert not bar.progress.live.is_started


def test_in_a_notebook_redraws_are_spaced_but_the_last_state_is_always_drawn():
    shown = _Handle()
    bar = _bar(notebook=True, display=shown, refresh_seconds=3600.0)
    task = bar.add_task("sample S1", total=10)
    bar.start()
    for done in range(1, 11):
        bar.update(task, completed=done)
    bar.stop()
    assert len(shown.shown) == 2
    assert "10 of 10" in _text(shown.shown[-1])


def test_in_a_terminal_it_is_rich_live_display():
    bar = _bar(notebook=False)
    bar.progress.console.file = io.StringIO()
    task = bar.add_task("sample S1", total=2)
    bar.start()
    assert bar.progress.live.is_started
    bar.update(task, completed=2)
    bar.stop()
    assert not bar.progress.live.is_started
    assert bar.tasks[0].finished


def test_the_notebook_output_is_html_wide_enough_for_a_long_line_of_numbers():
    shown = _Handle()
    bar = LiveProgress(TextColumn("{task.description}"), BarColumn(),
                       TextColumn("{task.fields[info]}"), notebook=True, display=shown)
    info = "step 829 (224 of <= 200000 in the stage)  q/p 0.266  packing fraction 0.5545  " \
           "z 3.52  I 8.7e-04 (<= 0.001)"
    task = bar.add_task("shear", total=1.0, info=info)
    bar.start()
    bar.update(task, completed=0.5)
    bar.stop()
    last = shown.shown[-1]
    html = last._repr_html_()
    assert html.startswith("<pre")
    assert "shear" in html and "(&lt;= 0.001)" in html  # nothing cut
    assert "━" in repr(last) and repr(last).rstrip().endswith("(<= 0.001)")
