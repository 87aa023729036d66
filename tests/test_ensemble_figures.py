"""The ensemble's energy figure puts every member where its axis says (a swept value on a
numeric axis, unmoved; the member index without a sweep, labelled), and its store opens in
xarray without a warning (consolidated metadata)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from s2gen.ensemble import ensemble
from s2gen.ensemble.figures import energy_plot
from s2gen.ensemble.store import EnsembleStore


def _strip(path: Path) -> tuple[dict[str, np.ndarray], object]:
    store = EnsembleStore.open(path)
    per = store.per_member()
    fig = energy_plot(per, store.attrs)
    return per, fig.axes[0]


def _points(ax: object, label: str) -> np.ndarray:
    (collection,) = [c for c in ax.collections if c.get_label() == label]  # type: ignore[attr-defined]
    return np.asarray(collection.get_offsets())


@pytest.fixture(scope="module")
def swept(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("swept")
    sweep = {"g": [5.0, 10.0, 15.0]}
    return ensemble("double_pendulum", 4, {"omega": 1e-9}, sweep, T=0.1, workers=0, out=out).path


def test_a_numeric_sweep_axis_shows_the_swept_values_unmoved(swept: Path) -> None:
    per, ax = _strip(swept)
    refs, perturbed = _points(ax, "reference"), _points(ax, "perturbed")
    assert refs[:, 0].tolist() == [5.0, 10.0, 15.0]
    assert set(perturbed[:, 0].tolist()) == {5.0, 10.0, 15.0} and len(perturbed) == 9
    np.testing.assert_array_equal(refs[:, 1], per["mean_dE"][per["replica"] == 0])
    assert ax.get_xlabel() == "g"


def test_without_a_sweep_the_x_axis_is_the_labelled_member_index(tmp_path: Path) -> None:
    r = ensemble("double_pendulum", 5, {"omega": 1e-9}, T=0.1, workers=0, out=tmp_path)
    _, ax = _strip(r.path)
    assert _points(ax, "reference")[:, 0].tolist() == [0.0]
    assert _points(ax, "perturbed")[:, 0].tolist() == [1.0, 2.0, 3.0, 4.0]
    assert ax.get_xlabel().startswith("member")


def test_a_grid_keeps_its_references_on_their_points(tmp_path: Path) -> None:
    sweep = {"g": [5.0, 10.0], "m2": [1.0, 2.0]}
    r = ensemble("double_pendulum", 3, {"omega": 1e-9}, sweep, T=0.1, workers=0, out=tmp_path)
    per, ax = _strip(r.path)
    refs, perturbed = _points(ax, "reference"), _points(ax, "perturbed")
    assert refs[:, 0].tolist() == [0.0, 1.0, 2.0, 3.0]
    points = per["point"][per["replica"] != 0]
    assert np.all(np.abs(perturbed[:, 0] - points) <= 0.25)
    assert ax.get_xlabel().startswith("sweep point")


def test_the_store_opens_in_xarray_without_a_warning(swept: Path) -> None:
    import xarray as xr

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds = xr.open_zarr(swept)
    assert ds["q"].dims == ("member", "sample", "body", "component")
    assert ds["energy"].shape[0] == 12
