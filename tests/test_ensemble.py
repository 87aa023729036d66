"""Ensembles on Dask (localhost only): every member's stored samples are compared with the same
member integrated directly through the public API (`s2gen.compile(...).integrate`), so the
cluster, the transport and the store must change nothing, wherever a member ran."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import s2gen
from s2gen.cli import main
from s2gen.ensemble import (
    EnsembleError,
    EnsembleStore,
    ensemble,
    fit_lyapunov,
    initial_state,
    member_table,
)
from s2gen.ensemble.store import STATISTICS, TRAJECTORIES
from s2gen.experiments.reproduce.band import chaos_band
from s2gen.methods import Status
from s2gen.runtime import IntegrationError
from s2gen.runtime.options import Options

pytest.importorskip("distributed")

Client = pytest.importorskip("distributed").Client
LocalCluster = pytest.importorskip("distributed").LocalCluster


# ------------------------------------------------------------------------------------ helpers
def _direct(
    system: Any, table: Any, every: int, method: str = "vi", options: Options | None = None
) -> list[dict[str, Any]]:
    """Each member integrated on its own through the public API: samples (thinned) and status."""
    model = s2gen.compile(system)
    out = []
    for m in table.members:
        q0, w0 = initial_state(system, table, m)
        status = 0
        try:
            tr = model.integrate(
                method, m.h, table.T, q0=q0, omega0=w0, params=dict(m.params), options=options
            )
        except IntegrationError as exc:
            tr, status = exc.partial, exc.status
        dev = np.abs(tr.energy - tr.energy[0])
        out.append(
            {
                "status": status,
                "samples": len(tr.t),
                "q": tr.q[::every],
                "omega": tr.omega[::every],
                "energy": tr.energy[::every],
                "t": tr.t[::every],
                "mean_dE": dev.mean(),
                "max_dE": dev.max(),
            }
        )
    return out


def _assert_store_equals(path: Path, expected: list[dict[str, Any]]) -> None:
    """The store's samples are bit-identical to the direct runs, NaN after a member's last."""
    import zarr

    g = zarr.open_group(str(path), mode="r")
    for i, e in enumerate(expected):
        assert int(g["status"][i]) == e["status"], i
        assert int(g["samples"][i]) == e["samples"], i
        assert g["mean_dE"][i] == e["mean_dE"] and g["max_dE"][i] == e["max_dE"], i
        for name in TRAJECTORIES:
            stored = np.asarray(g[name][i])
            k = len(e[name])
            assert np.array_equal(stored[:k], e[name]), (i, name)
            assert np.isnan(stored[k:]).all(), (i, name)


@pytest.fixture(scope="module")
def local_client() -> Iterator[Any]:
    """A LocalCluster of two worker processes (one thread each)."""
    cluster = LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    )
    client = Client(cluster)
    yield client
    client.close()
    cluster.close()


# ------------------------------------------------------------------------------ member table
def test_members_are_seeded_unit_tangent_and_reproducible() -> None:
    s = s2gen.load("elastic_rod")
    table = member_table(s, 5, {"q": 1e-9, "omega": 1e-9}, {"kappa": "100:1000:2"}, seed=3)
    assert len(table) == 10 and [m.replica for m in table.members[:5]] == [0, 1, 2, 3, 4]
    ref_q, ref_w = initial_state(s, table, table.members[0])
    assert np.array_equal(ref_q, s.q0) and np.array_equal(ref_w, s.omega0)
    states = [initial_state(s, table, m) for m in table.members]
    for q, w in states[1:5]:
        assert np.abs(np.linalg.norm(q, axis=1) - 1).max() < 1e-15
        assert np.abs(np.einsum("ij,ij->i", q, w)).max() < 1e-12
        dq = np.linalg.norm(q - s.q0, axis=1)
        assert np.allclose(dq, 1e-9, rtol=1e-5)  # relative size: |q_i| = 1
        scale = np.linalg.norm(s.omega0, axis=1).max()  # omega moves by its own 1e-9 * scale
        assert 0 < np.linalg.norm(w - s.omega0, axis=1).max() <= 2.01e-9 * scale  # + re-projection
    only_omega = member_table(s, 2, {"omega": 1e-9})
    q, w = initial_state(s, only_omega, only_omega.members[1])
    assert np.array_equal(q, s.q0) and np.abs(np.einsum("ij,ij->i", q, w)).max() < 1e-12
    assert np.allclose(np.linalg.norm(w - s.omega0, axis=1), 1e-9 * 10.0, rtol=1e-5)
    # the same replica gets the same perturbation at every sweep point, different ones differ
    assert np.array_equal(states[1][0], states[6][0]) and np.array_equal(states[1][1], states[6][1])
    assert not np.array_equal(states[1][0], states[2][0])
    again = member_table(s, 5, {"q": 1e-9, "omega": 1e-9}, {"kappa": "100:1000:2"}, seed=3)
    assert np.array_equal(initial_state(s, again, again.members[3])[0], states[3][0])
    other = member_table(s, 5, {"q": 1e-9, "omega": 1e-9}, seed=4)
    assert not np.array_equal(initial_state(s, other, other.members[3])[0], states[3][0])
    assert [dict(m.params)["kappa"] for m in table.members[4:6]] == [100.0, 1000.0]


def test_lyapunov_fit_recovers_a_known_exponent() -> None:
    """Exponential growth at rate 1.7 from 1e-13, with noise, saturating at 1."""
    rng = np.random.default_rng(1)
    t = np.linspace(0, 25, 2501)
    d = np.minimum(1e-13 * np.exp(1.7 * t) * np.exp(0.05 * rng.standard_normal(t.size)), 1.0)
    fit = fit_lyapunov(t, np.log(d))
    assert fit.rate is not None and abs(fit.rate - 1.7) < 0.02
    assert 1e-12 <= 1e-13 * math.exp(1.7 * fit.t_start) <= 2e-12
    assert fit.t_end < math.log(1e13) / 1.7
    flat = fit_lyapunov(t, np.log(1e-13 * (1 + t)))
    assert flat.rate is None and "3 decades" in flat.reason


# --------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--sweep", "kapa=1:2:3"], "unknown sweep parameter 'kapa'"),
        (["--sweep", "kappa=100:1000"], "expected START:STOP:COUNT"),
        (["--sweep", "kappa100"], "expected NAME=VALUE"),
        (["--perturb", "p=1e-13"], "cannot perturb 'p'"),
        (["--sweep", "h=0.3", "--T", "1"], "not a whole number of steps"),
        (["--chaos-band", "--T", "3"], "drop --T"),
        (["--bench", "--sweep", "kappa=1,2"], "no --sweep"),
        (["--dashboard"], "--workers 0 has none"),
        (["--max-steps", "-1"], "max_steps = -1"),
    ],
)
def test_bad_input_is_one_line_exit_2(
    argv: list[str], message: str, capsys: Any, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    assert main(["ensemble", "elastic_rod", *argv, "--workers", "0", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and message in err[0]
    assert not out.exists()  # nothing written


@pytest.mark.parametrize("package", ["dask", "distributed", "zarr"])
def test_missing_package_is_one_line_naming_its_install_command(
    package: str, tmp_path: Path
) -> None:
    """With one of the ensemble's packages unimportable (None in sys.modules, in a child
    process), the command refuses in one line that says what to install; nothing is written."""
    out = tmp_path / "out"
    argv = ["ensemble", "double_pendulum", "--perturb", "omega=1e-13", "--T", "0.1"]
    argv += ["--workers", "2", "--out", str(out)]
    code = (
        f"import sys\nsys.modules[{package!r}] = None\n"
        f"from s2gen.cli import main\nsys.exit(main({argv!r}))\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        f"error: s2gen.ensemble needs {package}, which is not installed: pip install {package}"
    ]
    assert not out.exists()


def test_missing_store_package_is_an_import_error_of_the_python_api(tmp_path: Path) -> None:
    """`import s2gen.ensemble` works without zarr; the call that needs it raises ImportError."""
    code = (
        "import sys\nsys.modules['zarr'] = None\nimport s2gen.ensemble\n"
        "try:\n"
        f"    s2gen.ensemble.ensemble('double_pendulum', T=0.1, workers=0, out={str(tmp_path)!r})\n"
        "except ImportError as exc:\n    print(exc)\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    )
    assert proc.stdout == "s2gen.ensemble needs zarr, which is not installed: pip install zarr\n"
    assert not (tmp_path / "ensemble.zarr").exists()


def test_chaos_band_needs_the_runner_the_command_line_passes_in(tmp_path: Path) -> None:
    """The core's ensemble command knows no paper example: --chaos-band runs only through the
    runner that `s2gen ensemble` passes it from the reproduce experiment."""
    import argparse

    from s2gen.ensemble import add_parser, run

    parser = argparse.ArgumentParser()
    add_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["ensemble", "elastic_rod", "--chaos-band", "--out", str(tmp_path)])
    with pytest.raises(EnsembleError, match="needs the paper examples of s2gen reproduce"):
        run(args)
    seen = []
    assert run(args, chaos_band=lambda a, perturb: seen.append((a.spec, perturb)) or 7) == 7
    assert seen == [("elastic_rod", {})]


def test_unreachable_scheduler_is_one_line_exit_2(tmp_path: Path) -> None:
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-m", "s2gen", "ensemble", "double_pendulum"]
        + ["--scheduler", "tcp://127.0.0.1:9", "--timeout", "1", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in lines[0]
    assert not out.exists()


# --------------------------------------------------------------------------------- the store
def test_store_layout_and_numbers_match_direct_runs(tmp_path: Path) -> None:
    s = s2gen.load("double_pendulum")
    r = ensemble(
        s, 3, {"omega": 1e-12}, {"g": [5.0, 9.81]}, T=0.5, every=5, workers=0, out=tmp_path
    )
    import zarr

    g = zarr.open_group(str(r.path), mode="r")
    for name, dims in TRAJECTORIES.items():
        assert tuple(g[name].metadata.dimension_names) == dims
    assert g["q"].shape == (6, 11, 2, 3) and g["energy"].shape == (6, 11)  # 50 steps / 5 + 1
    for name in [*STATISTICS, "member", "point", "replica", "seed", "perturb_q", "perturb_omega"]:
        assert tuple(g[name].metadata.dimension_names) == ("member",), name
    assert g["param_g"][:].tolist() == [5.0] * 3 + [9.81] * 3
    assert g["replica"][:].tolist() == [0, 1, 2] * 2
    assert g["perturb_omega"][:].tolist() == [0.0, 1e-12, 1e-12] * 2
    assert g["body"][:].tolist() == [1, 2] and g["component"][:].tolist() == [0, 1, 2]
    assert g.attrs["s2gen"]["method"] == "vi" and g.attrs["s2gen"]["every"] == 5
    table = member_table(s, 3, {"omega": 1e-12}, {"g": [5.0, 9.81]}, T=0.5)
    _assert_store_equals(r.path, _direct(s, table, every=5))
    unit = np.abs(np.linalg.norm(np.asarray(g["q"][:]), axis=3) - 1)
    assert np.nanmax(unit) <= np.nanmax(g["max_unit"][:]) < 1e-13  # stats cover every sample


def test_the_step_budget_reaches_every_member(tmp_path: Path) -> None:
    """--max-steps is each member's RK45 step budget: the members stop where integrate() with
    the same budget stops them, and the store records the option."""
    out = tmp_path / "out"
    argv = ["ensemble", "double_pendulum", "--members", "2", "--perturb", "omega=1e-12"]
    argv += ["--method", "rk45", "--T", "0.5", "--max-steps", "2", "--workers", "0"]
    assert main([*argv, "--no-figures", "--out", str(out)]) == 0
    s = s2gen.load("double_pendulum")
    table = member_table(s, 2, {"omega": 1e-12}, T=0.5)
    expected = _direct(s, table, every=1, method="rk45", options=Options(max_steps=2))
    assert [e["status"] for e in expected] == [Status.STEPSIZE] * 2
    store = out / "ensemble.zarr"
    _assert_store_equals(store, expected)
    import zarr

    attrs = zarr.open_group(str(store), mode="r").attrs["s2gen"]
    assert attrs["options"]["max_steps"] == 2 and "--max-steps 2" in attrs["command"]


def test_interrupted_ensemble_keeps_the_members_written(tmp_path: Path) -> None:
    s = s2gen.load("double_pendulum")
    seen: list[int] = []

    def stop_after_three(result: Any) -> None:
        seen.append(result.index)
        if len(seen) == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        ensemble(s, 6, {"q": 1e-12}, T=0.3, workers=0, out=tmp_path, progress=stop_after_three)
    store = EnsembleStore.open(tmp_path)
    assert store.written().tolist() == [True] * 3 + [False] * 3
    table = member_table(s, 6, {"q": 1e-12}, T=0.3)
    expected = _direct(s, table, every=1)[:3]
    _assert_store_equals(store.path, expected)


def test_a_task_that_raises_is_recorded_and_the_rest_go_on(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from s2gen.ensemble import dispatch, worker

    def flaky(payload: Any, task: Any) -> Any:
        if task.index == 1:
            raise RuntimeError("disk full on the worker")
        return worker.run_member(payload, task)

    monkeypatch.setattr(dispatch, "run_member", flaky)
    r = ensemble("double_pendulum", 3, {"omega": 1e-13}, T=0.2, workers=0, out=tmp_path)
    assert r.written == 3 and r.task_errors == (1,) and r.failed == ()
    store = EnsembleStore.open(tmp_path)
    assert store.per_member()["status"].tolist() == [0, worker.TASK_ERROR, 0]
    assert "disk full on the worker" in store.attrs["task_errors"]["1"]
    assert np.isnan(np.asarray(store.array("q")[1])).all()


# ------------------------------------------------------------------------------ on clusters
def test_local_cluster_is_bit_identical_to_serial(local_client: Any, tmp_path: Path) -> None:
    s = s2gen.load("double_pendulum")
    kw: dict[str, Any] = {"perturb": {"omega": 1e-13}, "sweep": {"g": [9.81, 20.0]}, "T": 0.5}
    par = ensemble(s, 4, **kw, every=2, client=local_client, out=tmp_path / "par")
    ser = ensemble(s, 4, **kw, every=2, workers=0, out=tmp_path / "ser")
    assert par.workers == 2 and par.written == 8 and sorted(par.order) == list(range(8))
    a, b = EnsembleStore.open(par.path), EnsembleStore.open(ser.path)
    for name in a.names():
        if name not in ("wall_time", "setup_time"):
            x, y = np.asarray(a.array(name)[:]), np.asarray(b.array(name)[:])
            assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name
    table = member_table(s, 4, kw["perturb"], kw["sweep"], T=0.5)
    _assert_store_equals(par.path, _direct(s, table, every=2))
    # each worker loaded the model at most once (the first of its members)
    assert (a.per_member()["setup_time"] > 0).sum() <= 2


def _assert_same_stores(a: EnsembleStore, b: EnsembleStore) -> None:
    """Every array of two stores equal (NaN where NaN), the timings aside."""
    assert a.names() == b.names()
    for name in a.names():
        if name not in ("wall_time", "setup_time"):
            x, y = np.asarray(a.array(name)[:]), np.asarray(b.array(name)[:])
            assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name


def test_batches_of_members_per_task_change_nothing(local_client: Any, tmp_path: Path) -> None:
    """Three members per Dask task (a sweep point's members split across tasks, one member
    that fails inside its batch) and four per store write serially give the store of one
    member at a time, and that of each member integrated on its own."""
    s = s2gen.load("three_bodies")
    kw: dict[str, Any] = {"perturb": {"omega": 1e-13}, "sweep": {"gamma": [1.0, 30.0]}}
    kw.update(T=0.5, h=0.01, every=2)
    par = ensemble(s, 4, **kw, client=local_client, out=tmp_path / "par", batch_size=3)
    ser = ensemble(s, 4, **kw, workers=0, out=tmp_path / "ser", batch_size=4)
    one = ensemble(s, 4, **kw, workers=0, out=tmp_path / "one")
    assert par.written == ser.written == one.written == 8 and par.failed == one.failed != ()
    for other in (par, ser):
        _assert_same_stores(EnsembleStore.open(other.path), EnsembleStore.open(one.path))
    table = member_table(s, 4, kw["perturb"], kw["sweep"], T=0.5, h=0.01)
    _assert_store_equals(par.path, _direct(s, table, every=2))
    with pytest.raises(ValueError, match="batch_size = 0"):
        ensemble(s, 2, T=0.1, workers=0, out=tmp_path / "bad", batch_size=0)


def test_fresh_workers_load_their_models_while_the_run_sets_up(tmp_path: Path) -> None:
    """On a local cluster of fresh workers, the models are loaded in the run's set-up (each
    worker's warm-up), not inside the first members' tasks: no member carries a load, the
    result counts the loads, and the store is the serial run's."""
    s = s2gen.load("double_pendulum")
    kw: dict[str, Any] = {"perturb": {"omega": 1e-13}, "T": 0.5, "every": 5}
    par = ensemble(s, 16, **kw, workers=2, out=tmp_path / "par")
    ser = ensemble(s, 16, **kw, workers=0, out=tmp_path / "ser")
    assert par.workers == 2 and par.written == 16 and par.worker_setup_time > 0.0
    a = EnsembleStore.open(par.path)
    assert (a.per_member()["setup_time"] == 0.0).all()
    _assert_same_stores(a, EnsembleStore.open(ser.path))


def test_batch_size_by_measurement() -> None:
    """About TARGET_TASK_SECONDS of integration per task, at most MAX_BATCH members, and
    never so many that some task slot stays empty."""
    from s2gen.ensemble.dispatch import MAX_BATCH, TARGET_TASK_SECONDS, batch_size_for

    assert batch_size_for(TARGET_TASK_SECONDS / 10, 10_000, 4) == 10
    assert batch_size_for(1e-9, 10_000, 4) == MAX_BATCH
    assert batch_size_for(1e-4, 40, 8) == 5
    assert batch_size_for(10.0, 10_000, 4) == 1


def test_failed_member_keeps_partial_samples_and_status(local_client: Any, tmp_path: Path) -> None:
    """gamma = 30 makes the explicit VI step of three bodies infeasible at step 18."""
    s = s2gen.load("three_bodies")
    r = ensemble(s, sweep={"gamma": [1.0, 30.0]}, T=0.5, h=0.01, client=local_client, out=tmp_path)
    assert r.written == 2 and r.failed == (1,)
    per = EnsembleStore.open(r.path).per_member()
    assert per["status"].tolist() == [0, int(Status.INFEASIBLE)]
    assert 1 < per["samples"][1] < 51
    table = member_table(s, sweep={"gamma": [1.0, 30.0]}, T=0.5, h=0.01)
    expected = _direct(s, table, every=1)
    assert expected[1]["status"] == Status.INFEASIBLE
    _assert_store_equals(r.path, expected)


@pytest.fixture()
def scheduler_address(tmp_path: Path) -> Iterator[str]:
    """`dask scheduler` and two `dask worker` processes on 127.0.0.1, started and stopped here."""
    info = tmp_path / "scheduler.json"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    procs = [
        subprocess.Popen(
            [sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1", "--port", "0"]
            + ["--no-dashboard", "--scheduler-file", str(info)],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    ]
    try:
        deadline = time.monotonic() + 30
        while not info.exists() or not info.read_text().strip():
            assert time.monotonic() < deadline, "scheduler did not start"
            time.sleep(0.1)
        address = json.loads(info.read_text())["address"]
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [sys.executable, "-m", "dask", "worker", address, "--nthreads", "1"]
                    + ["--no-nanny", "--no-dashboard", "--local-directory", str(tmp_path)],
                    env=env,
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                )
            )
        with Client(address, timeout="20s") as c:
            c.wait_for_workers(2, timeout=30)
        yield address
    finally:
        for p in reversed(procs):  # workers first (no nannies: no child processes left behind)
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=5)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def test_separate_scheduler_and_workers_by_address(scheduler_address: str, tmp_path: Path) -> None:
    out = tmp_path / "out"
    argv = ["ensemble", "double_pendulum", "--members", "4", "--perturb", "q=1e-13"]
    argv += ["--T", "0.5", "--every", "5", "--scheduler", scheduler_address, "--out", str(out)]
    assert main(argv) == 0
    store = EnsembleStore.open(out)
    assert store.written().all()
    s = s2gen.load("double_pendulum")
    _assert_store_equals(store.path, _direct(s, member_table(s, 4, {"q": 1e-13}, T=0.5), 5))
    assert (out / "summary.md").exists() and (out / "divergence.png").exists()


def test_killed_worker_mid_ensemble(tmp_path: Path) -> None:
    """SIGKILL a worker that is running a member: the ensemble completes, each member once,
    results equal to the direct runs."""
    s = s2gen.load("double_pendulum")
    perturb, T, h = {"omega": 1e-13}, 0.6, 5e-6  # 120 000 steps: ~0.1 s per member
    cluster = LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    )
    client = Client(cluster)
    killed: list[int] = []

    def kill_a_busy_worker(result: Any) -> None:
        """At a result, wait until a worker holds a member and kill it. The ensemble hands out
        work only between these calls, so a call gives up after 2 s with no worker busy (every
        task handed out so far had finished) and the next result tries again."""
        if killed:
            return
        deadline = time.monotonic() + 2.0
        while time.monotonic() < deadline:
            pids = client.run(os.getpid)
            for address, keys in client.processing().items():
                if keys and address in pids:
                    os.kill(pids[address], signal.SIGKILL)
                    killed.append(pids[address])
                    return
            time.sleep(0.005)

    try:
        r = ensemble(
            s, 10, perturb, h=h, T=T, every=1000, client=client, out=tmp_path,
            progress=kill_a_busy_worker,
        )  # fmt: skip
    finally:
        client.close()
        cluster.close()
    assert killed, "no worker was busy when the first member arrived"
    assert r.written == 10 and sorted(r.order) == list(range(10)) and not r.task_errors
    _assert_store_equals(r.path, _direct(s, member_table(s, 10, perturb, h=h, T=T), 1000))


def test_chaos_band_of_a_paper_example(tmp_path: Path) -> None:
    """The band's unperturbed member is the run `s2gen reproduce` reports (same metric, same
    units), and the band is ordered."""
    from s2gen.experiments.reproduce import EXAMPLES, integrate
    from s2gen.metrics import energy_variation

    bands = chaos_band("double_pendulum", members=3, workers=0, out=tmp_path, log=lambda _: None)
    ex = EXAMPLES["double_pendulum"]
    assert [b.method for b in bands] == [r.method for r in ex.runs]
    system = s2gen.load(ex.system)
    for band, run in zip(bands, ex.runs):
        tr = integrate(system, run, log=lambda _: None)
        assert band.reference == energy_variation(tr.energy)[0] / ex.energy_unit
        assert band.members == 3 and band.minimum <= band.median <= band.maximum
        assert len(band.values) == 3 and min(band.values) == band.minimum
        assert max(band.values) == band.maximum
    assert (tmp_path / "band.md").read_text().count("| double_pendulum |") == 2
    assert (tmp_path / "band.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_rod_chaos_band_holds_the_papers_values(tmp_path: Path) -> None:
    """64 perturbed rods (T = 3, h = 1e-4): the VI and RK45 bands contain the paper's figures."""
    bands = chaos_band("elastic_rod", members=64, workers=2, out=tmp_path, log=lambda _: None)
    assert [b.method for b in bands] == ["vi", "rk45"]
    assert all(b.members == 64 and b.contains_paper() for b in bands)
