"""Out-of-core and distributed preprocessing on Dask (auralize.distributed)."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("dask")
pytest.importorskip("distributed")

from auralize.cli import core as cli
from auralize.datasets import make_explosion
from auralize.distributed import (
    RunError,
    Runner,
    SchedulerError,
    StateStore,
    chunked_volume,
    detect_distributed,
    plan_chunks,
    plan_slabs,
    render_distributed,
    to_dask,
    volume_from_dask,
    write_chunked_explosion,
)
from auralize.emitters.synthesis import render_tracks
from auralize.errors import DataError, MissingDependencyError, ParameterError
from auralize.io import open_volume
from auralize.listener import ListenerPath
from auralize.sources import SourceSeries, SourceTracks, Thresholds, detect
from auralize.sources.sources_file import load_sources_h5
from auralize.volume import TimeVolume

# dask.distributed's own start-up/shut-down chatter, not ours
pytestmark = [
    pytest.mark.filterwarnings("ignore:Port .* is already in use:UserWarning"),
    pytest.mark.filterwarnings("ignore:.*unclosed.*:ResourceWarning"),
    pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning"),
    pytest.mark.filterwarnings("ignore:.*Creating scratch directories.*:UserWarning"),
]


def scale(series: SourceSeries) -> dict[str, Any]:
    """What the distributed run reports about itself."""
    out = series.meta["scale"]
    assert isinstance(out, dict)
    return out


def assert_same_sources(a: SourceSeries, b: SourceSeries) -> None:
    """Bit-identical index, kind, strength and radius at every step."""
    assert a.n_steps == b.n_steps
    for n, (f, g) in enumerate(zip(a.frames, b.frames, strict=True)):
        for name in ("index", "kind", "strength", "radius"):
            x, y = getattr(f, name), getattr(g, name)
            assert x.dtype == y.dtype, (n, name)
            assert np.array_equal(x, y), (n, name)
    assert np.array_equal(a.thresholds, b.thresholds)


@pytest.fixture(scope="module")
def explosion() -> TimeVolume:
    return make_explosion(size=20, steps=7, seed=3).load()


@pytest.fixture(scope="module")
def explosion_ref(explosion: TimeVolume) -> SourceSeries:
    ref = detect(explosion, mapping="paper-density")
    assert sum(c["monopole"] + c["dipole"] + c["quadrupole"] for c in ref.counts()) > 100
    return ref


@dataclass
class CountingFrames:
    """An in-memory field that records which steps were read (sync/threads only)."""

    array: np.ndarray
    reads: list[int]
    bad_step: int | None = None

    @property
    def n_steps(self) -> int:
        return int(self.array.shape[0])

    @property
    def frame_shape(self) -> tuple[int, ...]:
        return tuple(self.array.shape[1:])

    def read(self, step: int) -> np.ndarray:
        self.reads.append(step)
        if step == self.bad_step:
            return np.zeros((2, 2, 2))
        return np.array(self.array[step], dtype=np.float64)


def counting_volume(vol: TimeVolume, reads: list[int], bad_step: int | None = None) -> TimeVolume:
    arrays = {k: np.stack(list(vol.iter_frames(k))) for k in vol.field_names}
    return TimeVolume(
        origin=vol.origin,
        spacing=vol.spacing,
        dims=vol.dims,
        times=vol.times,
        fields={k: CountingFrames(a, reads, bad_step) for k, a in arrays.items()},
        source="counting",
    )


# ------------------------------------------------------------------ imports
def test_import_auralize_does_not_import_dask() -> None:
    code = (
        "import sys, auralize, auralize.distributed, auralize.cli.distributed, auralize.bench.distributed; "
        "print('dask' in sys.modules, 'distributed' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


def test_missing_dask_names_the_install_command(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "dask", None)
    with pytest.raises(MissingDependencyError, match=r"pip install .*auralize\[dask\]"):
        Runner("threads")


# ---------------------------------------------------------- chunked volumes
def test_to_dask_reads_one_step_per_chunk(explosion: TimeVolume) -> None:
    arr = to_dask(explosion, "velocity")
    assert arr.shape == (7, 20, 20, 20, 3)
    assert arr.chunks[0] == (1,) * 7
    got = arr[2:5].compute(scheduler="sync")
    assert np.array_equal(got, np.stack([explosion.frame("velocity", n) for n in (2, 3, 4)]))


def test_chunked_file_matches_in_memory_detection_across_chunk_borders(
    tmp_path: Path, explosion_ref: SourceSeries
) -> None:
    f = write_chunked_explosion(
        tmp_path / "big.h5", 20, 7, 3, generator="particles", dtype="float64"
    )
    vol = open_volume(f)
    assert np.array_equal(
        vol.frame("log10_density", 4),
        make_explosion(size=20, steps=7, seed=3).frame("log10_density", 4),
    )
    # relative thresholds: peaks and the paper mapping's statistics come from tasks too
    got = detect_distributed(vol, mapping="paper-density", chunk_steps=3, slab_planes=4, log=None)
    assert scale(got)["chunks"] == 3  # time borders at steps 3 and 6
    assert len(scale(got)["slabs"]) == 5  # z borders every 4 planes
    assert_same_sources(got, explosion_ref)
    # the same with absolute thresholds, on Dask-array-backed frames
    thr = Thresholds(*explosion_ref.thresholds)
    got = detect_distributed(
        chunked_volume(vol),
        mapping="paper-density",
        thresholds=thr,
        chunk_steps=2,
        slab_planes=6,
        log=None,
    )
    assert_same_sources(got, explosion_ref)


def test_all_local_schedulers_and_a_local_cluster_match_sync(
    explosion: TimeVolume, explosion_ref: SourceSeries
) -> None:
    thr = Thresholds(*explosion_ref.thresholds)
    for sched in ("threads", "distributed"):
        with Runner(sched, workers=2, processes=False, log=None) as run:
            assert run.n_workers == 2
            got = detect_distributed(
                explosion,
                mapping="paper-density",
                thresholds=thr,
                runner=run,
                chunk_steps=2,
                slab_planes=5,
            )
        assert scale(got)["workers"] == 2
        assert_same_sources(got, explosion_ref)


def test_plans() -> None:
    assert plan_chunks([0, 1, 2, 3, 4, 7, 8, 10], 2) == [(0, 2), (2, 4), (4, 5), (7, 9), (10, 11)]
    slabs = plan_slabs((20, 8, 8), ghost=3, planes=6)
    assert [(s.z0, s.z1) for s in slabs] == [(0, 5), (5, 10), (10, 15), (15, 20)]
    assert all(s.r0 == max(s.z0 - 3, 0) and s.r1 == min(s.z1 + 3, 20) for s in slabs)
    assert len(plan_slabs((20, 8, 8), ghost=None, planes=4)) == 1
    with pytest.raises(ParameterError, match="chunk_steps must be a positive integer"):
        plan_chunks([1], 0)
    # a run is cut into equal chunks (±1), not full chunks and a short remainder:
    # two workers get the same work
    assert plan_chunks(range(12), 10) == [(0, 6), (6, 12)]
    assert plan_chunks(range(7), 3) == [(0, 3), (3, 5), (5, 7)]
    assert plan_chunks(range(100), 10) == [(a, a + 10) for a in range(0, 100, 10)]


def test_preparation_passes_run_one_task_per_chunk_and_slab(
    explosion: TimeVolume, explosion_ref: SourceSeries, monkeypatch: pytest.MonkeyPatch
) -> None:
    from auralize.distributed import detect as D

    calls: dict[str, int] = {}
    graphs: list[int] = []

    def counted(fn: Any) -> Any:
        def task(*a: Any) -> Any:
            calls[fn.__name__] = calls.get(fn.__name__, 0) + 1
            return fn(*a)

        return task

    for name in (
        "paper_range_task",
        "paper_gradient_task",
        "peak_task",
        "steady_task",
        "detect_task",
    ):
        monkeypatch.setattr(D, name, counted(getattr(D, name)))
    real = Runner.compute

    def compute(self: Runner, outputs: Any, on_result: Any) -> None:
        graphs.append(len(outputs))
        real(self, outputs, on_result)

    monkeypatch.setattr(Runner, "compute", compute)
    got = D.detect_distributed(
        explosion, mapping="paper-density", chunk_steps=4, slab_planes=10, log=None
    )
    assert len(scale(got)["slabs"]) == 2 and scale(got)["chunks"] == 2  # steps [0, 4), [4, 7)
    # range and gradient: every step; peaks: the sample steps; one task per chunk × slab;
    # the steady state's anchor steps: one task per block of steps (one block of 8
    # here) × slab
    assert calls == {
        "paper_range_task": 4,
        "paper_gradient_task": 4,
        "peak_task": 4,
        "steady_task": 2,
        "detect_task": 4,
    }
    # all passes are one graph: the mapping, the peaks, the thresholds, the steady
    # strength and 4 detections
    assert graphs == [4 + 4]
    assert_same_sources(got, explosion_ref)


def test_detection_tasks_save_their_own_sources(tmp_path: Path, explosion: TimeVolume) -> None:
    from auralize.distributed.detect import Slab, detect_task
    from auralize.sources.mapping import get_mapping

    m = get_mapping("identity", density="log10_density")
    m.prepare(explosion)
    thr = np.array([0.5, 5.0, 50.0])
    slab = Slab(0, 20, 0, 20)
    mem = detect_task(explosion, m, thr, 1.0, 2, 5, slab, 1)
    store = StateStore(tmp_path / "s.h5")
    assert StateStore.in_dir(str(store.dir)).dir == store.dir
    disk = detect_task(explosion, m, thr, 1.0, 2, 5, slab, 1, str(store.dir))
    # the task wrote its piece and returned only the count
    assert disk["frames"] is None and disk["count"] == sum(f.index.size for f in mem["frames"])
    assert disk["count"] > 0
    store.promote_piece(2, 5, 0)
    assert store.done_steps() == {2, 3, 4} and not list(store.dir.glob("piece_*"))
    with np.load(store.dir / "steps_0000002-0000005.npz") as z:
        off = z["offsets"]
        for k, f in enumerate(mem["frames"]):
            for name in ("index", "kind", "strength", "radius"):
                assert np.array_equal(getattr(f, name), z[name][off[k] : off[k + 1]])
    with pytest.raises(ParameterError, match="not a detection state folder"):
        StateStore.in_dir(tmp_path)


def test_cluster_workers_are_set_up_before_their_first_task() -> None:
    from auralize.distributed.worker_setup import tune_allocator

    with Runner("distributed", workers=1, processes=True, log=None) as run:
        (rep,) = run.worker_setup
        assert rep["kernels"] is True and "error" not in rep and rep["seconds"] > 0
        assert rep["pid"] != os.getpid() and run.setup_seconds >= rep["seconds"]
        # glibc large-array reuse restored (Dask's nanny sets MALLOC_TRIM_THRESHOLD_)
        assert rep["allocator"] is (sys.platform.startswith("linux") and tune_allocator())
        # the statistical profiler is off in the worker process (~9 % of a busy task's CPU)
        (prof,) = run.client.run(_profiler_enabled).values()
        assert prof is False
    with Runner(
        "distributed", workers=1, processes=False, log=None, setup_workers=False, profile=True
    ) as run:
        assert run.worker_setup == []
        (prof,) = run.client.run(_profiler_enabled).values()
        assert prof is True


def _profiler_enabled(dask_worker: Any) -> bool:
    """Whether a worker samples its threads' stacks (its profiling loop is running)."""
    pc = dask_worker.periodic_callbacks.get("profile")
    return bool(pc is not None and pc.is_running())


# ---------------------------------------------------------------- resuming
@pytest.mark.filterwarnings("ignore::auralize.sources.SourceFractionWarning")  # low thresholds
def test_interrupted_run_resumes_without_redoing_finished_steps(
    tmp_path: Path, explosion: TimeVolume
) -> None:
    vol = TimeVolume.from_arrays(
        {
            "density": np.stack([10 ** explosion.frame("log10_density", n) for n in range(7)]),
            "velocity": np.stack(list(explosion.iter_frames("velocity"))),
        },
        times=explosion.times,
    )
    thr = Thresholds(0.5, 5.0, 50.0)
    ref = detect(vol, mapping="identity", thresholds=thr)
    out = tmp_path / "sources.h5"
    saved: list[range] = []

    def stop_after_two(steps: range) -> None:
        saved.append(steps)
        if len(saved) == 2:
            raise KeyboardInterrupt

    reads: list[int] = []
    with pytest.raises(KeyboardInterrupt):
        detect_distributed(
            counting_volume(vol, reads),
            thresholds=thr,
            output=out,
            chunk_steps=2,
            on_chunk=stop_after_two,
            log=None,
        )
    assert not out.exists()
    done = StateStore(out).done_steps()
    assert len(saved) == 2 and done == set(saved[0]) | set(saved[1]) and 3 <= len(done) <= 4
    todo = sorted(set(range(7)) - done)
    reads.clear()
    got = detect_distributed(
        counting_volume(vol, reads), thresholds=thr, output=out, chunk_steps=2, log=None
    )
    sc = scale(got)
    assert sc["computed_steps"] == todo and sc["resumed_steps"] == len(done)
    # only the missing steps and their neighbours were read (two on each side for the
    # discretisation floor's 2Δt stencil), and the steady state's anchor steps
    near = {m for n in todo for m in (n - 1, n, n + 1) if 0 <= m < 7}
    assert (
        near
        <= set(reads)
        <= near | {m for n in todo for m in (n - 2, n + 2) if 0 <= m < 7} | {0, 6}
    )
    assert_same_sources(got, ref)
    assert_same_sources(load_sources_h5(out), ref)
    assert not StateStore(out).dir.exists()


@pytest.mark.filterwarnings("ignore::auralize.sources.SourceFractionWarning")  # low thresholds
def test_resume_refuses_state_of_other_settings(tmp_path: Path, explosion: TimeVolume) -> None:
    out = tmp_path / "s.h5"

    def stop(_steps: range) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        detect_distributed(
            explosion,
            mapping="paper-density",
            thresholds=Thresholds(1, 1, 1),
            output=out,
            chunk_steps=3,
            on_chunk=stop,
            log=None,
        )
    with pytest.raises(ParameterError, match="other settings.*restart"):
        detect_distributed(
            explosion, mapping="paper-density", thresholds=Thresholds(2, 1, 1), output=out, log=None
        )
    got = detect_distributed(
        explosion,
        mapping="paper-density",
        thresholds=Thresholds(2, 1, 1),
        output=out,
        restart=True,
        log=None,
    )
    assert scale(got)["resumed_steps"] == 0 and out.exists()


# --------------------------------------------------------------- bad input
def test_unreachable_scheduler_is_a_clear_error() -> None:
    with pytest.raises(
        SchedulerError,
        match=r"no Dask scheduler answered at tcp://127.0.0.1:9 "
        r"within 2 s",
    ):
        Runner("distributed", address="tcp://127.0.0.1:9", timeout=2, log=None).__enter__()
    with pytest.raises(ParameterError, match="unknown scheduler 'gpu'"):
        Runner("gpu")
    with pytest.raises(ParameterError, match="workers must be a positive integer, got 0"):
        Runner("threads", workers=0)


def test_chunks_of_mismatched_shapes_are_refused(explosion: TimeVolume) -> None:
    import dask.array as da

    with pytest.raises(DataError, match=r"field 'v' has shape \(4, 3, 3, 2, 3\).*same"):
        volume_from_dask({"rho": da.ones((4, 3, 3, 3)), "v": da.ones((4, 3, 3, 2, 3))})
    with pytest.raises(DataError, match=r"got \(4, 3, 3\)"):
        volume_from_dask({"rho": da.ones((4, 3, 3))})
    reads: list[int] = []
    vol = counting_volume(explosion, reads, bad_step=4)
    with pytest.raises(DataError, match=r"step 4.*shape \(2, 2, 2\)"):
        to_dask(vol, "velocity").compute(scheduler="sync")
    with pytest.raises(DataError, match=r"step 4: the frame source returned shape \(2, 2, 2\)"):
        detect_distributed(
            vol, mapping="paper-density", thresholds=Thresholds(1, 1, 1), slab_planes=8, log=None
        )


# ------------------------------------------------------------- dying workers
@dataclass
class DyingFrames:
    """Kills the worker process reading ``step`` while ``marker`` exists (once if ``once``)."""

    base: object
    step: int
    marker: str
    once: bool

    @property
    def n_steps(self) -> int:
        return self.base.n_steps  # type: ignore[attr-defined]

    @property
    def frame_shape(self) -> tuple[int, ...]:
        return self.base.frame_shape  # type: ignore[attr-defined]

    def read(self, step: int) -> np.ndarray:
        if step == self.step and os.path.exists(self.marker):
            if self.once:
                os.unlink(self.marker)
            os._exit(1)
        return self.base.read(step)  # type: ignore[attr-defined]


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::auralize.sources.SourceFractionWarning")  # log10 as density
def test_worker_dying_mid_run_fails_over_or_stops_resumably(
    tmp_path: Path, explosion: TimeVolume, explosion_ref: SourceSeries
) -> None:
    import cloudpickle
    import dask

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    src = tmp_path / "vol.h5"
    from auralize.io import save_volume

    save_volume(explosion, src)
    base = open_volume(src)
    thr = Thresholds(*explosion_ref.thresholds)
    marker = tmp_path / "die"

    def dying(once: bool) -> TimeVolume:
        fields: dict[str, Any] = {
            k: DyingFrames(v, 5, str(marker), once) for k, v in base.fields.items()
        }
        return TimeVolume(
            origin=base.origin,
            spacing=base.spacing,
            dims=base.dims,
            times=base.times,
            fields=fields,
            source=base.source,
        )

    out = tmp_path / "s.h5"
    with (
        dask.config.set({"distributed.scheduler.allowed-failures": 1}),
        Runner("distributed", workers=2, processes=True, log=None) as run,
    ):
        # a worker dies once: its task is re-run on a live worker; same sources
        marker.touch()
        got = detect_distributed(
            dying(True), mapping="paper-density", thresholds=thr, runner=run, chunk_steps=2
        )
        assert not marker.exists()  # it did die
        assert_same_sources(got, explosion_ref)
        # a task that kills every worker it runs on: the run stops, finished chunks saved
        # (identity mapping, steady part kept: no statistics pass, so the deaths happen
        # in detection tasks)
        marker.touch()
        ident = {
            "mapping": "identity",
            "density": "log10_density",
            "thresholds": thr,
            "chunk_steps": 2,
            "steady": "keep",
        }
        with pytest.raises(RunError, match="killed the workers.*run again to resume"):
            detect_distributed(dying(False), runner=run, output=out, **ident)  # type: ignore[arg-type]
    done = StateStore(out).done_steps()
    assert done <= {0, 1, 2, 3} and not out.exists()  # chunks [4, 6) and [6, 7) read step 5
    marker.unlink()
    got = detect_distributed(base, output=out, log=None, **ident)  # type: ignore[arg-type]
    assert scale(got)["resumed_steps"] == len(done)
    assert_same_sources(
        got,
        detect(base, mapping="identity", density="log10_density", thresholds=thr, steady="keep"),
    )


# --------------------------------------------------------------- synthesis
def test_distributed_synthesis_blocks_join_without_seams(
    explosion: TimeVolume, explosion_ref: SourceSeries
) -> None:
    tracks = explosion_ref.tracks()
    path = ListenerPath.orbit(explosion.center, radius=6.0, duration=0.4, turns=0.3)
    whole = render_tracks(tracks, path, rate=16000, layout="ring8").audio
    with Runner("threads", workers=2, log=None) as run:
        got = render_distributed(
            tracks, path, rate=16000, layout="ring8", block_seconds=0.037, groups=4, runner=run
        )
    assert got.meta["blocks"] == 11 and got.meta["groups"] == 4 and got.meta["tasks"] == 44
    assert got.audio.shape == whole.shape == (8, 6400)
    assert np.max(np.abs(got.audio - whole)) <= 1e-9 * np.max(np.abs(whole))
    # one block (the default for a short output), source groups only
    one = render_distributed(tracks, path, rate=16000, layout="ring8", groups=3, log=None)
    assert one.meta["blocks"] == 1 and one.meta["groups"] == 3
    assert np.max(np.abs(one.audio - whole)) <= 1e-9 * np.max(np.abs(whole))
    # on a local cluster the groups travel packed (scattered, one worker each)
    with Runner("distributed", workers=2, processes=False, log=None) as run:
        dist = render_distributed(
            tracks, path, rate=16000, layout="ring8", groups=3, block_seconds=0.15, runner=run
        )
        # inputs placed one at a time go to the workers in turn, and a
        # generator of calls is submitted as it is produced
        placed = list(run.place_each(np.full(3, k) for k in range(4)))
        owners = run.client.who_has(placed)
        first = [next(iter(owners[f.key])) for f in placed]
        assert first[0] != first[1] and first[0] == first[2] and first[1] == first[3]
        got_sums: dict[int, float] = {}
        run.run(((np.sum, (f,)) for f in placed), lambda i, r: got_sums.update({i: r}))
        assert got_sums == {k: 3.0 * k for k in range(4)}
    assert dist.meta["groups"] == 3 and dist.meta["blocks"] == 3 and dist.meta["workers"] == 2
    assert np.max(np.abs(dist.audio - whole)) <= 1e-9 * np.max(np.abs(whole))
    with pytest.raises(ParameterError, match="block_seconds must be > 0"):
        render_distributed(tracks, path, block_seconds=0.0, log=None)
    with pytest.raises(ParameterError, match="groups must be a positive integer"):
        render_distributed(tracks, path, groups=0, log=None)


def test_packed_tracks_travel_as_their_nonzero_strengths(explosion_ref: SourceSeries) -> None:
    import pickle

    from auralize.distributed.synth import PackedTracks

    tr = explosion_ref.tracks()
    packed = PackedTracks(tr)
    blob = pickle.dumps(packed, protocol=5)
    nnz, k = np.count_nonzero(tr.q), tr.n_sources
    # 12 bytes per non-zero strength (uint32 position, float64 value), 40 per source
    assert nnz < tr.q.size and len(blob) <= 12 * nnz + 40 * k + (64 << 10)
    back = pickle.loads(blob)
    got = back.tracks()
    assert got is back.tracks()  # unpacked once per process, then reused (with its caches)
    assert np.array_equal(got.q, tr.q) and np.array_equal(got.positions, tr.positions)
    assert np.array_equal(got.radius, tr.radius) and np.array_equal(got.times, tr.times)
    assert pickle.loads(pickle.dumps(back))._tracks is None  # the unpacked copy stays here
    # a striped group: its ranges, in order
    k3 = k // 3
    part = PackedTracks(tr, [(k3, 2 * k3), (0, 5)]).tracks()
    want = np.concatenate([tr.q[k3 : 2 * k3], tr.q[:5]])
    assert np.array_equal(part.q, want) and part.n_sources == k3 + 5
    assert np.array_equal(
        part.positions, np.concatenate([tr.positions[k3 : 2 * k3], tr.positions[:5]])
    )


def test_task_plan_groups_many_pieces_and_blocks_long_outputs() -> None:
    from auralize.distributed.synth import BLOCK_VALUES, PIECES_PER_GROUP, plan_tasks

    def tracks(k: int, t: int, dense: bool) -> SourceTracks:
        q = np.ones((k, t)) if dense else np.zeros((k, t))
        q[:, 0] = 1.0
        return SourceTracks(
            positions=np.zeros((k, 3)), q=q, radius=np.ones(k), times=np.arange(float(t))
        )

    # few pieces: one group, the parallelism from blocks (two tasks per worker)
    block, groups = plan_tasks(tracks(100, 10, True), 44100, 8, 2)
    assert groups == 1 and block == 11025
    # many pieces: source groups, one block
    many = tracks(PIECES_PER_GROUP // 4, 32, True)  # 8 groups' worth
    block, groups = plan_tasks(many, 44100, 8, 2)
    assert groups == 4 and block == 44100
    # a long output is cut in blocks of at most BLOCK_VALUES values
    n = 3 * BLOCK_VALUES // 8 + 5
    block, groups = plan_tasks(many, n, 8, 2)
    assert block * 8 <= BLOCK_VALUES and -(-n // block) == 4


def test_source_groups_are_contiguous_balanced_and_cover_every_source() -> None:
    from auralize.distributed.synth import source_groups

    q = np.zeros((100, 32))
    q[:50, :] = 1.0  # the first half sounds at every knot, the second once
    q[50:, 0] = 1.0
    tr = SourceTracks(positions=np.zeros((100, 3)), q=q, radius=np.ones(100), times=np.arange(32.0))
    g = [r for (r,) in source_groups(tr, 4)]  # one range per group
    assert g[0][0] == 0 and g[-1][1] == 100
    assert all(a < b for a, b in g) and all(g[i][1] == g[i + 1][0] for i in range(len(g) - 1))
    # by work, not by count: three of four groups go to the busy first half
    assert sum(b <= 50 for a, b in g) == 3
    even = SourceTracks(
        positions=np.zeros((5, 3)), q=np.ones((5, 8)), radius=np.ones(5), times=np.arange(8.0)
    )
    assert source_groups(even, 1000) == [[(k, k + 1)] for k in range(5)]  # ≤ one per source
    assert (
        source_groups(
            SourceTracks(np.zeros((0, 3)), np.zeros((0, 4)), np.zeros(0), np.arange(4.0)), 3
        )
        == []
    )


def test_striped_source_groups_interleave_and_balance() -> None:
    """Each group takes every n-th of n × stripes ranges of equal weight: all
    groups sample the whole volume (the cost of a piece depends on where its
    source is), every source is in one group, the weights are equal."""
    from auralize.distributed.synth import source_groups

    rng = np.random.default_rng(3)
    q = (rng.random((4000, 20)) < np.linspace(0.05, 0.6, 4000)[:, None]).astype(float)
    tr = SourceTracks(
        positions=np.zeros((4000, 3)), q=q, radius=np.ones(4000), times=np.arange(20.0)
    )
    groups = source_groups(tr, 4, stripes=8)
    assert len(groups) == 4 and all(len(r) == 8 for r in groups)
    flat = sorted(r for g in groups for r in g)
    assert flat[0][0] == 0 and flat[-1][1] == 4000
    assert all(flat[i][1] == flat[i + 1][0] for i in range(len(flat) - 1))  # a partition
    # interleaved: group g holds ranges g, g + 4, ... of the sorted list
    assert all(groups[i % 4][i // 4] == flat[i] for i in range(32))
    work = [sum(np.count_nonzero(q[a:b]) for a, b in g) for g in groups]
    assert max(work) / min(work) < 1.05
    # every group reaches both ends (contiguous groups would be slabs)
    assert all(g[0][1] <= flat[3][1] and g[-1][0] >= flat[28][0] for g in groups)
    (one,) = source_groups(tr, 1, stripes=8)
    assert len(one) == 8 and one[0][0] == 0 and one[-1][1] == 4000


def test_distributed_synthesis_renders_every_block_in_a_task(
    explosion: TimeVolume, explosion_ref: SourceSeries, monkeypatch: pytest.MonkeyPatch
) -> None:
    from auralize.distributed import synth

    sizes: list[int] = []
    real = synth.render_tracks

    def spy(*a: Any, **k: Any) -> Any:
        out = real(*a, **k)
        sizes.append(out.audio.shape[1])
        return out

    monkeypatch.setattr(synth, "render_tracks", spy)
    path = ListenerPath.orbit(explosion.center, radius=6.0, duration=0.4, turns=0.3)
    got = render_distributed(
        explosion_ref.tracks(), path, rate=16000, layout="ring8", block_seconds=0.1, log=None
    )
    # the caller only validates (renders nothing); every (block, group) is a task
    # (few sounding pieces: one group, see plan_tasks)
    assert got.meta["blocks"] == 4 and got.meta["groups"] == 1
    assert sizes == [1600] * 4


# ------------------------------------------------------------------- recipe
def test_chunked_recipe_bad_input_leaves_no_file(tmp_path: Path) -> None:
    with pytest.raises(ParameterError, match="generator='spline'"):
        write_chunked_explosion(tmp_path / "a.h5", 8, 3, generator="spline")  # type: ignore[arg-type]
    with pytest.raises(FileNotFoundError, match="does not exist"):
        write_chunked_explosion(tmp_path / "no" / "a.h5", 8, 3)
    with pytest.raises(ParameterError, match="--size must be an integer"):
        write_chunked_explosion(tmp_path / "a.h5", 2, 3)
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------- CLI
@pytest.mark.filterwarnings("ignore::auralize.sources.SourceFractionWarning")  # low thresholds
def test_cli_dataset_chunked_and_detect_on_dask(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    assert "auralize.cli.distributed" in cli.CORE_COMMAND_MODULES
    vol = tmp_path / "big.h5"
    assert (
        cli.main(
            [
                "dataset",
                "explosion",
                "--chunked",
                "--size",
                "16",
                "--steps",
                "5",
                "--generator",
                "analytic",
                "-o",
                str(vol),
            ]
        )
        == 0
    )
    assert open_volume(vol).dims == (16, 16, 16)
    thr = [
        "--threshold-monopole",
        "0.5",
        "--threshold-dipole",
        "20",
        "--threshold-quadrupole",
        "500",
    ]
    assert cli.main(["detect", str(vol), "-o", str(tmp_path / "serial.h5"), *thr]) == 0
    assert (
        cli.main(
            [
                "detect",
                str(vol),
                "-o",
                str(tmp_path / "dask.h5"),
                *thr,
                "--scheduler",
                "threads",
                "--workers",
                "2",
                "--chunk-steps",
                "2",
                "--slab-planes",
                "5",
            ]
        )
        == 0
    )
    assert "2 workers (threads)" in capsys.readouterr().out
    assert_same_sources(
        load_sources_h5(tmp_path / "dask.h5"), load_sources_h5(tmp_path / "serial.h5")
    )
    wav = tmp_path / "a.wav"
    assert (
        cli.main(
            [
                "render",
                str(vol),
                "--sources",
                str(tmp_path / "dask.h5"),
                "-o",
                str(wav),
                "--listener",
                "7,7,7",
                "--duration",
                "0.2",
                "--layout",
                "ring8",
                "--scheduler",
                "threads",
                "--workers",
                "2",
            ]
        )
        == 0
    )
    assert wav.exists() and "source groups) on 2 workers" in capsys.readouterr().out
    code = cli.main(
        [
            "scale-detect",
            str(vol),
            "-o",
            str(tmp_path / "x.h5"),
            *thr,
            "--address",
            "tcp://127.0.0.1:9",
            "--timeout",
            "1",
        ]
    )
    assert code == 4  # a system error
    assert "no Dask scheduler answered at tcp://127.0.0.1:9" in capsys.readouterr().err
    assert not (tmp_path / "x.h5").exists()


# ----------------------------------------------------- bounded client memory
def test_client_streams_chunks_to_the_output_file_without_holding_all_sources(
    tmp_path: Path,
    explosion: TimeVolume,
    explosion_ref: SourceSeries,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import gc

    import h5py

    from auralize.distributed import H5Frames
    from auralize.sources import SourceFrame
    from auralize.sources.sources_file import save_sources_h5

    def never(*_a: object, **_k: object) -> None:
        raise AssertionError("the client loaded every step's sources")

    monkeypatch.setattr(StateStore, "load_frames", never)

    def alive() -> int:
        gc.collect()
        # type(), not isinstance(): gc also lists weak proxies, whose isinstance()
        # raises ReferenceError once their referent is gone
        return sum(1 for o in gc.get_objects() if issubclass(type(o), SourceFrame))

    base = alive()
    held: list[int] = []
    out = tmp_path / "s.h5"
    got = detect_distributed(
        explosion,
        mapping="paper-density",
        thresholds=Thresholds(*explosion_ref.thresholds),
        output=out,
        chunk_steps=1,
        slab_planes=5,
        on_chunk=lambda _r: held.append(alive()),
        log=None,
    )
    slabs, chunks = len(scale(got)["slabs"]), scale(got)["chunks"]
    assert slabs >= 2 and chunks == 7 and len(held) == chunks
    # slab pieces wait on disk: at most one chunk's frames (7 steps × 5 pieces in all)
    # are alive in the client, whatever order the tasks finish in
    assert max(held) - base <= slabs + 1
    assert not list(StateStore(out).dir.glob("piece_*"))
    assert isinstance(got.frames, H5Frames) and alive() == base
    assert_same_sources(got, explosion_ref)
    # the streamed file has the same content as the one written from the whole series
    ref = tmp_path / "ref.h5"
    save_sources_h5(replace_frames(got, list(got.frames)), ref)
    with h5py.File(out, "r") as a, h5py.File(ref, "r") as b:
        assert sorted(a) == sorted(b) and dict(a.attrs).keys() == dict(b.attrs).keys()
        for k in b.attrs:
            assert np.array_equal(a.attrs[k], b.attrs[k]), k
        for k in b:
            assert a[k].dtype == b[k].dtype and a[k].shape == b[k].shape, k
            assert np.array_equal(a[k][()], b[k][()]), k
    assert got.frames[-1].index.size == got.frames[6].index.size
    assert [f.index.size for f in got.frames[2:4]] == [
        f.index.size for f in explosion_ref.frames[2:4]
    ]


def replace_frames(series: SourceSeries, frames: list[Any]) -> SourceSeries:
    from dataclasses import replace

    return replace(series, frames=frames)


def test_resume_with_slab_pieces_of_an_unfinished_chunk_left_over(
    tmp_path: Path, explosion: TimeVolume, explosion_ref: SourceSeries
) -> None:
    out = tmp_path / "s.h5"
    thr = Thresholds(*explosion_ref.thresholds)
    kw: dict[str, Any] = {
        "mapping": "paper-density",
        "thresholds": thr,
        "output": out,
        "chunk_steps": 2,
        "slab_planes": 5,
        "log": None,
    }

    def stop(_steps: range) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        detect_distributed(explosion, on_chunk=stop, **kw)
    store = StateStore(out)
    done = store.done_steps()
    # one chunk finished before the stop: [0, 1], [2, 3], [4, 5] or the short [6]
    # (chunks finish in any order)
    assert len(done) in (1, 2) and not out.exists()
    # a slab of a chunk that never completed (as after a crash)
    a = min(set(range(7)) - done)
    store.write_piece(a, 0, explosion_ref.frames[a : a + 1])
    got = detect_distributed(explosion, **kw)
    assert scale(got)["resumed_steps"] == len(done)
    assert_same_sources(got, explosion_ref)
    assert_same_sources(load_sources_h5(out), explosion_ref)
    assert not store.dir.exists()


def test_no_data_points_give_the_same_sources_in_slabs(explosion: TimeVolume) -> None:
    # a validity mask and NaN cells: slabs see the mask's planes and read no no-data point
    x = np.stack(list(explosion.iter_frames("log10_density")))
    valid = np.ones(explosion.shape, dtype=bool)
    valid[:, :, :5] = False
    valid[12:, 3:9, :] = False
    x[:, ~valid] = np.nan
    x[3, 10, 10, 10] = np.nan
    vol = TimeVolume.from_arrays({"log10_density": x}, times=explosion.times)
    vol.check_finite = False
    vol.valid = valid  # type: ignore[attr-defined]
    ref = detect(vol, mapping="paper-density")
    assert sum(f.index.size for f in ref.frames) > 100
    assert all(valid.reshape(-1)[f.index].all() for f in ref.frames)
    got = detect_distributed(vol, mapping="paper-density", chunk_steps=3, slab_planes=4, log=None)
    assert len(scale(got)["slabs"]) > 1
    assert_same_sources(got, ref)
    assert got.meta["fraction"] == pytest.approx(ref.meta["fraction"])
