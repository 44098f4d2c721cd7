"""The time step of a contact-dynamics stage, grown while the overlaps stay small.

A Moreau-Jean step solved to a finite tolerance leaves a few contacts approaching at a small
speed; contact dynamics never pushes an overlap back at once, so what a step cannot hold
shows as overlap (docs/explanations/time-step.md, "The time step"). The overlap is the error of the
step, and it sets how long the step may be: the sweeps a step needs do not grow with its
length (1000 spheres in shear: 502 / 364 / 291 sweeps a step at v h / d_min = 0.003 / 0.006 /
0.01), so a longer step saves time nearly in proportion, until the overlaps grow.

:class:`OverlapStepControl` keeps a scale s in [1, growth] of the stage's step h_0
(``time_step_factor`` x d_min / v) and after every step compares the largest overlap of that
step's detection, delta, with the bound delta_b (``overlap_bound`` x the mean diameter):

* delta > delta_b: s <- max(1, s / 2) (the step halves at once);
* delta < delta_b / 2: s <- min(growth, s x :data:`GROWTH_RATE`) (it grows by a few % a step);
* otherwise s stays.

A stage starts at s = 1, so a stage that cannot keep its overlaps below the bound runs as with
a fixed step h_0, and a longer step is taken only where the overlaps show it is held. The
decisions read the detection's gaps only (the same on any thread count), and s is part of a
run's checkpoint.

>>> control = OverlapStepControl(growth=2.0, bound=1e-3)
>>> [round(control.after_step(overlap=0.0), 3) for _ in range(3)]
[1.05, 1.103, 1.158]
>>> control.after_step(overlap=2e-3)
1.0
"""

from __future__ import annotations

from grainlab._validate import at_least, in_range

GROWTH_RATE = 1.05
"""Factor by which the scale of the step grows after a step whose largest overlap is below
half the bound [-]: from h_0 to 2 h_0 in 15 steps."""

SHRINK_RATE = 0.5
"""Factor by which the scale of the step shrinks after a step whose largest overlap exceeds
the bound [-]."""


class OverlapStepControl:
    """The scale s of a stage's step, in [1, ``growth``], from the largest overlap of each
    step (module docstring).

    Parameters
    ----------
    growth:
        Largest scale [-], >= 1 (1: the step stays h_0).
    bound:
        Largest overlap [m], > 0, above which the step shortens.
    scale:
        The scale to start from [-] (a resumed run's), in [1, growth].
    """

    def __init__(self, growth: float, bound: float, scale: float = 1.0) -> None:
        self.growth = at_least("time_step_growth", growth, 1.0, strict=False)
        self.bound = at_least("overlap_bound", bound)
        self.scale = in_range("step scale", scale, 1.0, self.growth, closed="[]")

    def after_step(self, overlap: float) -> float:
        """The scale of the next step [-] after a step whose detection met ``overlap`` [m]
        as its largest overlap."""
        if overlap > self.bound:
            self.scale = max(1.0, self.scale * SHRINK_RATE)
        elif overlap < 0.5 * self.bound:
            self.scale = min(self.growth, self.scale * GROWTH_RATE)
        return self.scale
