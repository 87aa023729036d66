"""Readability of the reproduction figures: step-size tick labels do not collide, the rod's
snapshot times do not cover its 3-D panel, and the kinetic-energy figure says where the sphere
is seen from."""

from __future__ import annotations

import re

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from s2gen.experiments.reproduce import figures
from s2gen.experiments.reproduce.paper import EXAMPLES, PaperRun
from s2gen.experiments.reproduce.records import ExampleResult, RunResult
from s2gen.runtime import simulate
from s2gen.systems import builtin


def _overlapping_labels(fig: Figure, ax: object) -> list[tuple[str, str]]:
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    labels = [t for t in ax.xaxis.get_ticklabels(which="both") if t.get_text() and t.get_visible()]  # type: ignore[attr-defined]
    boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in labels]
    return [
        (a, b)
        for i, (a, box_a) in enumerate(boxes)
        for b, box_b in boxes[i + 1 :]
        if box_a.overlaps(box_b)
    ]


def _log_panel(label_steps: bool) -> tuple[Figure, object]:
    """A panel as wide as the figure's (16 in / 3) over the quick runs' step sizes."""
    fig = Figure(figsize=(16 / 3, 4.8), layout="constrained")
    ax = fig.add_subplot()
    ax.plot([5e-4, 5e-3], [1e-6, 1e-4])
    ax.set(xscale="log", yscale="log")
    if label_steps:
        figures._label_step_sizes(ax, [5e-4, 5e-3])
    return fig, ax


def test_step_size_tick_labels_do_not_collide() -> None:
    fig, ax = _log_panel(label_steps=False)
    assert _overlapping_labels(fig, ax), "matplotlib's default no longer collides: drop the fix?"
    fig, ax = _log_panel(label_steps=True)
    assert _overlapping_labels(fig, ax) == []
    texts = [t.get_text() for t in ax.xaxis.get_ticklabels() if t.get_text()]
    assert texts == [r"$5\times10^{-4}$", r"$5\times10^{-3}$"]


def _rod_example() -> ExampleResult:
    system = builtin("elastic_rod")
    run = PaperRun("vi", 1e-4, 0.01)
    tr = simulate(system, "vi", "c", h=run.h, T=run.T)
    ex = ExampleResult(EXAMPLES["elastic_rod"], quick=True, system=system)
    ex.runs.append(RunResult("elastic_rod", run, trajectory=tr))
    return ex


def test_rod_snapshot_times_are_a_colour_bar_beside_the_panel() -> None:
    ex = _rod_example()
    fig = Figure(figsize=(16, 4.8), layout="constrained")
    ax = fig.add_subplot(1, 3, 1, projection="3d")
    assert ex.system is not None
    figures._motion_rod(ax, ex.system, ex.runs[0])
    assert ax.get_legend() is None  # nothing drawn over the rod
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    bars = [a for a in fig.axes if a is not ax]
    assert len(bars) == 1 and "time" in bars[0].get_ylabel()
    bar = bars[0].get_tightbbox(renderer)
    assert ax.lines and not any(
        line.get_window_extent(renderer).overlaps(bar) for line in ax.lines
    )  # the colour bar, its ticks and label are clear of every snapshot


@pytest.mark.parametrize(
    ("view", "words"),
    [
        (np.array([0.0, 0.0, 1.0]), "(0.00, 0.00, 1.00) (elevation 90°"),
        (np.array([1.0, 0.0, 0.0]), "(1.00, 0.00, 0.00) (elevation 0°, azimuth 0°"),
        (np.array([0.0, -1.0, 0.0]), "(0.00, -1.00, 0.00) (elevation 0°, azimuth -90°"),
    ],
)
def test_kinetic_caption_says_where_the_sphere_is_seen_from(view: np.ndarray, words: str) -> None:
    caption = figures._view_caption(view).replace("\n", " ")
    assert words in caption and "Seen from outside the sphere" in caption


def test_kinetic_figure_carries_the_caption_and_the_axes(
    tmp_path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The view direction of the figure is the one its caption states (here the molecules'
    kinetic-energy-weighted mean direction, computed independently)."""
    system = builtin("molecular")
    tr = simulate(system, "vi", "c", h=0.005, T=0.01)
    ex = ExampleResult(EXAMPLES["molecular"], quick=True, system=system)
    ex.runs.append(RunResult("molecular", PaperRun("vi", 0.005, 0.01), trajectory=tr))
    captions: list[str] = []
    caption_of = figures._view_caption
    monkeypatch.setattr(
        figures, "_view_caption", lambda view: captions.append(caption_of(view)) or captions[-1]
    )
    path = figures._kinetic_figure(ex, tmp_path / "k.png")
    assert path.read_bytes()[:4] == b"\x89PNG"
    v = np.cross(tr.omega[0], tr.q[0])
    centre = np.einsum("ic,ic->i", v, v) @ tr.q[0]
    centre /= np.linalg.norm(centre)
    assert len(captions) == 1, "the figure carries one caption"
    caption = captions[0].replace("\n", " ")
    # the three printed components, compared as numbers with the independent centre: a
    # component of -2e-17 prints as 0.00 whatever its sign, and no text of the test's own is
    # compared with the caption's
    found = re.search(r"\(x, y, z\) = \((-?\d\.\d\d), (-?\d\.\d\d), (-?\d\.\d\d)\)", caption)
    assert found, caption
    printed = np.array([float(c) for c in found.groups()])
    assert np.all(np.abs(printed - centre) <= 0.005 + 1e-9)
    assert "-0.00" not in caption
