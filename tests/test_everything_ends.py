"""Everything ends, and every face says the same: full disks, huge step counts, failed allocations.

* A full disk ends a writer at its first failed write: exit 4 (an
  :class:`~auralize.errors.OutputError`) with one line naming the output,
  nothing left behind, no HDF5 diagnostics on stderr.  The CLI runs in a
  subprocess on a real 256 KiB tmpfs where one can be mounted; elsewhere the
  subprocess's writes beyond the room left are refused by the kernel
  (``RLIMIT_FSIZE``, set when the output's temporary is named).  Either way
  HDF5 itself sees the failed write, and the outcome asserted is the same.
* A volume whose steps x frame size is beyond the machine (memory, or the
  ``AURALIZE_DATA_LIMIT`` bound on the data one command reads) is refused by
  ``info`` and ``detect`` with the figure before any work; a long but small one
  is accepted.
* The API raises auralize's errors with the text the CLI prints.
* Chunked (Dask) frames read ±Inf as the volume's ``frame`` does.
"""

from __future__ import annotations

import errno
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

from auralize.cli import core as cli
from auralize.errors import OutputError, ParameterError, ResourceError
from auralize.io.vtkhdf_write import write_sources_vtkhdf, write_volume_vtkhdf
from auralize.runtime import files, resources
from auralize.volume import TimeVolume

ROOT = Path(__file__).resolve().parent.parent
TMPFS_BYTES = 256 * 1024

# The CLI in a subprocess.  LIMIT: the kernel refuses writes beyond ROOM bytes from the
# moment the output's temporary is named (no tmpfs).  LATE: no free-space check up front,
# so the disk fills during the write.
_DRIVER = """
import os, resource, signal, sys
import auralize.runtime.files as files
if os.environ.get("LIMIT"):
    room, name = int(os.environ["LIMIT"]), files.temp_name
    def limited(*a, **k):
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (room, room))
        return name(*a, **k)
    files.temp_name = limited
if os.environ.get("LATE"):
    import auralize.runtime.resources as resources
    resources.require_disk = lambda *a, **k: None
from auralize.cli import main
sys.exit(main(sys.argv[1:]))
"""


class FullDisk:
    """A folder with only ``room`` bytes left to write: a real small tmpfs, or a limit."""

    def __init__(self, folder: Path, mounted: bool) -> None:
        self.folder, self.mounted, self.limit = folder, mounted, 0

    def leave(self, room: int) -> None:
        if self.mounted:
            free = shutil.disk_usage(self.folder).free
            (self.folder / "filler").write_bytes(b"\0" * max(free - room, 0))
        else:
            self.limit = room

    def user_files(self) -> set[str]:
        return {p.name for p in self.folder.iterdir()} - {"filler"}

    def run(self, *argv: Any, late: bool = False) -> subprocess.CompletedProcess[str]:
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        env.pop("LIMIT", None)
        env.pop("LATE", None)
        if self.limit:
            env["LIMIT"] = str(self.limit)
        if late:
            env["LATE"] = "1"
        return subprocess.run(
            [sys.executable, "-c", _DRIVER, *map(str, argv)],
            env=env,
            capture_output=True,
            text=True,
            timeout=60,
        )


def _mount_tmpfs(folder: Path) -> bool:
    if not hasattr(os, "geteuid") or os.geteuid() != 0 or shutil.which("mount") is None:
        return False
    r = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={TMPFS_BYTES}", "tmpfs", str(folder)],
        capture_output=True,
    )
    return r.returncode == 0


@pytest.fixture
def full_disk(tmp_path: Path) -> Iterator[FullDisk]:
    folder = tmp_path / "disk"
    folder.mkdir()
    mounted = _mount_tmpfs(folder)
    try:
        yield FullDisk(folder, mounted)
    finally:
        if mounted:
            subprocess.run(["umount", "-l", str(folder)], capture_output=True)


def _one_error_line(r: subprocess.CompletedProcess[str], out: Path) -> str:
    assert r.returncode == cli.EXIT_SYSTEM, (r.returncode, r.stderr[-2000:])
    assert "HDF5-DIAG" not in r.stderr and "Traceback" not in r.stderr, r.stderr[-2000:]
    assert all(line.startswith("auralize ") for line in r.stderr.splitlines()), r.stderr
    errors = [line for line in r.stderr.splitlines() if ": error: " in line]
    assert len(errors) == 1 and f"cannot write {str(out)!r}" in errors[0], r.stderr
    return errors[0]


@pytest.mark.parametrize("late", [False, True], ids=["checked", "fills-during-write"])
def test_detect_to_vtkhdf_on_a_full_disk_ends_with_one_line(
    full_disk: FullDisk, late: bool
) -> None:
    full_disk.leave(16 * 1024)
    out = full_disk.folder / "o.vtkhdf"
    r = full_disk.run(
        "detect", "dataset:monopole", "--size", "16", "--steps", "10", "-o", out, late=late
    )
    line = _one_error_line(r, out)
    assert "needs about" in line or ("about" in line and "needed" in line), line
    assert full_disk.user_files() == set()


@pytest.mark.parametrize("late", [False, True], ids=["checked", "fills-during-write"])
def test_volume_to_vtkhdf_on_a_full_disk_ends_with_one_line(
    full_disk: FullDisk, late: bool
) -> None:
    full_disk.leave(64 * 1024)
    out = full_disk.folder / "v.vtkhdf"
    r = full_disk.run("dataset", "monopole", "--size", "16", "--steps", "12", "-o", out, late=late)
    _one_error_line(r, out)
    assert full_disk.user_files() == set()


def test_a_write_that_fits_still_works_there(full_disk: FullDisk) -> None:
    full_disk.leave(200 * 1024)
    out = full_disk.folder / "s.vtkhdf"
    r = full_disk.run("detect", "dataset:monopole", "--size", "12", "--steps", "6", "-o", out)
    assert r.returncode == 0, r.stderr
    assert full_disk.user_files() == {"s.vtkhdf"}


# The HDF5 outputs of the CLI: argv, then the output's name.  HDF5 that meets a failed
# write can crash the process after the error line, not every time: each case runs 3 times.
_HDF5_OUTPUTS = {
    "sources": ("detect", "dataset:monopole", "--size", "16", "--steps", "10", "o.h5"),
    "volume": ("dataset", "monopole", "--size", "16", "--steps", "12", "v.h5"),
    "chunked": (
        "dataset",
        "explosion",
        "--chunked",
        "--size",
        "16",
        "--steps",
        "4",
        "--generator",
        "analytic",
        "c.h5",
    ),
}


@pytest.mark.parametrize("late", [False, True], ids=["checked", "fills-during-write"])
@pytest.mark.parametrize("output", list(_HDF5_OUTPUTS))
def test_hdf5_outputs_on_a_full_disk_end_with_one_line_every_time(
    full_disk: FullDisk, output: str, late: bool
) -> None:
    full_disk.leave(16 * 1024)
    *argv, name = _HDF5_OUTPUTS[output]
    out = full_disk.folder / name
    for _ in range(3):
        r = full_disk.run(*argv, "-o", out, late=late)
        assert r.returncode not in (139, -11), r.stderr[-2000:]  # no crash after the error line
        _one_error_line(r, out)  # exit 4, one line naming the output, no HDF5-DIAG
        assert full_disk.user_files() == set()


# The API in a subprocess whose writes beyond ROOM bytes are refused by the kernel from the
# moment the output's temporary is named; CODE writes OUT and an OutputError exits 4.
_API_DRIVER = """
import os, resource, signal, sys
import numpy as np
import auralize.runtime.files as files
from auralize.errors import OutputError
room, name = int(os.environ["ROOM"]), files.temp_name
def limited(*a, **k):
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (room, room))
    return name(*a, **k)
files.temp_name = limited
out = sys.argv[2]
try:
    exec(sys.argv[1])
except OutputError as exc:
    print(exc, file=sys.stderr)
    sys.exit(4)
"""

_API_WRITERS = {
    "sofa": "from auralize.spatial.hrtf import spherical_head_hrirs\n"
    "from auralize.spatial.sofa import write_sofa\n"
    "d = np.random.default_rng(0).normal(size=(40, 3))\n"
    "write_sofa(out, spherical_head_hrirs(d / np.linalg.norm(d, axis=1)[:, None], 32000))",
    "chunked": "from auralize.distributed import write_chunked_explosion\n"
    "write_chunked_explosion(out, 16, 4, 0, generator='analytic')",
    "vortex-texture": "from auralize_vortex.texture import Texture\n"
    "Texture(np.array([10.0]), np.ones((1, 8000)), 48000.0, 1.0).save(out)",
    "aero-texture": "from auralize_aero.shapes import get_section\n"
    "from auralize_aero.texture import SoundTexture\n"
    "g = np.random.default_rng(1).standard_normal((3, 2000, 2))\n"
    "SoundTexture(get_section('circle', 0.01), 10.0, 20000.0, np.linspace(0, 45, 3),"
    " g, g.copy(), np.full(3, 2000), np.full(3, 0.2), {}).save(out)",
}


@pytest.mark.parametrize("writer", list(_API_WRITERS))
def test_other_hdf5_writers_on_a_full_disk_raise_one_output_error(
    writer: str, tmp_path: Path
) -> None:
    out = tmp_path / "o.h5"
    env = dict(
        os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), str(ROOT / "plugins")]), ROOM="4096"
    )
    r = subprocess.run(
        [sys.executable, "-c", _API_DRIVER, _API_WRITERS[writer], str(out)],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == cli.EXIT_SYSTEM, (r.returncode, r.stderr[-2000:])
    assert "HDF5-DIAG" not in r.stderr and "Traceback" not in r.stderr, r.stderr[-2000:]
    assert r.stderr.count("\n") == 1 and r.stderr.startswith(f"cannot write {str(out)!r}: ")
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- the API, in process
def _volume(steps: int = 6) -> TimeVolume:
    rng = np.random.default_rng(1)
    return TimeVolume.from_arrays(
        {"p": rng.normal(size=(steps, 5, 6, 7))}, times=np.arange(steps) * 0.1
    )


def _enospc(*_a: Any, **_k: Any) -> None:
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_a_full_disk_stops_the_volume_writer_at_its_first_write(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = []

    def full(self: Any, key: Any, value: Any) -> None:
        calls.append(key)
        _enospc()

    monkeypatch.setattr(h5py.Dataset, "__setitem__", full)
    out = tmp_path / "v.vtkhdf"
    with pytest.raises(
        OutputError, match=r"cannot write '.*v\.vtkhdf': No space left on device \(about"
    ):
        write_volume_vtkhdf(_volume(), out)
    assert len(calls) == 1  # the first failed write ends it
    assert list(tmp_path.iterdir()) == []


def test_the_api_and_the_cli_say_the_same_about_a_full_disk(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(h5py.Dataset, "__setitem__", lambda *a: _enospc())
    out = tmp_path / "v.vtkhdf"
    with pytest.raises(OSError) as api:  # still an OSError for callers that catch those
        write_volume_vtkhdf(
            TimeVolume.from_arrays({"density": np.ones((2, 4, 4, 4))}, times=[0.0, 0.1]), out
        )
    code = cli.main(["dataset", "monopole", "--size", "4", "--steps", "2", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == cli.EXIT_SYSTEM and err.count("\n") == 1
    assert isinstance(api.value, OutputError)
    head = str(api.value).split(" (")[0]  # the figures (free space) are read at the time
    assert err.startswith(f"auralize dataset: error: {head} (about ")
    assert list(tmp_path.iterdir()) == []


def test_sources_writer_stops_and_leaves_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from auralize.pipeline import detect_sources

    series = detect_sources(_volume(4), mapping="identity", density="p")
    real = h5py.Group.create_dataset
    made = []

    def fails_third(self: Any, *a: Any, **k: Any) -> Any:
        made.append(a[0])
        if len(made) == 3:
            _enospc()
        return real(self, *a, **k)

    monkeypatch.setattr(h5py.Group, "create_dataset", fails_third)
    with pytest.raises(OutputError, match="No space left on device"):
        write_sources_vtkhdf(series, tmp_path / "s.vtkhdf")
    assert len(made) == 3 and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("writer", ["atomic_write", "write_pair", "write_collection"])
def test_plain_writers_name_the_output_not_their_temporary(
    writer: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(Path, "write_bytes", lambda *a: _enospc())
    monkeypatch.setattr(Path, "write_text", lambda *a, **k: _enospc())
    target = tmp_path / "o.csv"
    with pytest.raises(OutputError) as err:
        if writer == "atomic_write":
            files.atomic_write(target, b"t,x,y,z\n")
        elif writer == "write_pair":
            files.write_pair(target, lambda p: None, tmp_path / "o.csv.json", lambda h: b"{}")
        else:
            target = tmp_path / "o.pvd"
            files.write_collection(target, "o_data", lambda folder: [])
    text = str(err.value)
    assert text.startswith(f"cannot write {str(target)!r}: No space left on device"), text
    assert "\n" not in text and ".part" not in text
    assert list(tmp_path.iterdir()) == []


def test_hdf5_errors_of_a_failed_write_are_recognised() -> None:
    exc = RuntimeError(
        "Can't decrement id ref count (file write failed: time = now\n, filename = "
        "'/x/.o.h5.1-abc.part.h5', errno = 28, error message = 'No space left')"
    )
    assert files.is_disk_full(exc)
    text, code = cli.error_message(exc, "o.h5")
    assert code == cli.EXIT_SYSTEM and text.startswith(
        "cannot write 'o.h5': No space left on device"
    )
    assert "\n" not in text
    # a failure to read an input stays a data error, not the output's
    assert not files.is_disk_full(OSError(errno.EIO, "Can't read data"))


def test_a_failed_allocation_is_a_resource_error_with_the_figures() -> None:
    with pytest.raises(
        ResourceError,
        match=r"^rendering x: not enough memory \(an allocation of "
        r"728 TiB failed; .* is available\)",
    ):
        with resources.memory_guard("rendering x"):
            np.empty((10**7, 10**7))
    with pytest.raises(MemoryError):  # still a MemoryError for callers that catch those
        with resources.memory_guard("rendering x"):
            raise MemoryError
    with pytest.raises(MemoryError) as failed:
        np.empty((10**7, 10**7))
    text, code = cli.error_message(failed.value)
    assert code == cli.EXIT_SYSTEM
    assert text == str(resources.memory_error(failed.value, ""))
    assert text.startswith("not enough memory (an allocation of 728 TiB failed")


# --------------------------------------------------------------------------- steps x frame size
def _declared(path: Path, steps: int, n: int) -> Path:
    """A volume file that declares ``steps`` steps of n³ points (most of them fill values)."""
    with h5py.File(path, "w") as f:
        f.attrs["auralize_format"] = "volume"
        f.attrs["version"] = 1
        f["time"] = np.arange(steps) * 0.01
        g = f.create_group("grid")
        g.attrs["origin"], g.attrs["spacing"] = np.zeros(3), np.ones(3)
        ds = f.create_dataset(
            "fields/density", shape=(steps, n, n, n), dtype="f8", chunks=(1, n, n, n), fillvalue=1.0
        )
        ds[: min(steps, 4)] = 1.0 + 0.01 * np.random.default_rng(0).normal(
            size=(min(steps, 4), n, n, n)
        )
    return path


@pytest.mark.parametrize("command", ["info", "detect"])
def test_a_million_steps_beyond_the_data_bound_are_refused_with_the_figure(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    vol = _declared(tmp_path / "big.h5", 1_000_000, 32)
    out = tmp_path / "s.h5"
    code = cli.main([command, str(vol)] + (["-o", str(out)] if command == "detect" else []))
    err = capsys.readouterr().err
    assert code == cli.EXIT_SYSTEM and err.count("\n") == 1, err
    assert "1000000 steps of 32 x 32 x 32 points is 244 GiB of data" in err
    assert "AURALIZE_DATA_LIMIT" in err and "refusing to start" in err
    assert not out.exists()


def test_a_step_count_beyond_the_memory_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    vol = _declared(tmp_path / "long.h5", 1_000_000, 8)
    monkeypatch.setenv("AURALIZE_MEMORY_LIMIT", "256M")
    assert cli.main(["info", str(vol)]) == cli.EXIT_SYSTEM
    err = capsys.readouterr().err
    assert (
        "1000000 steps of 8 x 8 x 8 points needs about 1.9" in err and "256 MiB is available" in err
    )


def test_a_time_array_beyond_the_memory_is_refused_before_it_is_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "absurd.h5"
    with h5py.File(path, "w") as f:  # declared, never written: nothing is stored
        f.attrs["auralize_format"], f.attrs["version"] = "volume", 1
        f.create_dataset("time", shape=(10**15,), dtype="f8", chunks=(1024,))
        g = f.create_group("grid")
        g.attrs["origin"], g.attrs["spacing"] = np.zeros(3), np.ones(3)
        f.create_dataset("fields/p", shape=(10**15, 2, 2, 2), dtype="f8", chunks=(1, 2, 2, 2))
    assert cli.main(["info", str(path)]) == cli.EXIT_SYSTEM
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{path}: 1000000000000000 time steps needs about" in err


def test_a_long_but_small_volume_still_works(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    vol = _declared(tmp_path / "long.h5", 10_000, 8)
    assert cli.main(["info", str(vol)]) == 0
    assert "10000 steps" in capsys.readouterr().out
    short = _declared(tmp_path / "short.h5", 1_500, 8)
    assert cli.main(["detect", str(short), "-o", str(tmp_path / "s.h5")]) == 0
    assert "wrote" in capsys.readouterr().out
    assert resources.require_volume((8, 8, 8), 10_000, 4, "long.h5") < resources.data_limit()


def test_the_data_bound_is_documented_and_adjustable(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    vol = _declared(tmp_path / "v.h5", 20, 8)
    monkeypatch.setenv("AURALIZE_DATA_LIMIT", "64K")
    assert cli.main(["detect", str(vol), "-o", str(tmp_path / "s.h5")]) == cli.EXIT_SYSTEM
    assert "above the 64 KiB one command reads (AURALIZE_DATA_LIMIT)" in capsys.readouterr().err
    monkeypatch.setenv("AURALIZE_DATA_LIMIT", "lots")
    with pytest.raises(ParameterError, match="AURALIZE_DATA_LIMIT='lots' is not a size"):
        resources.data_limit()
    assert cli.main(["info", str(vol)]) == cli.EXIT_USAGE
    assert "AURALIZE_DATA_LIMIT" in resources.__doc__  # type: ignore[operator]


def test_long_work_says_how_long_before_it_starts(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    assert resources.estimate_note(1e6) is None
    note = resources.estimate_note(30 * 2.0**30)
    assert note is not None and "30 GiB of data to read: about 13 min" in note
    monkeypatch.setattr(resources, "ESTIMATE_NOTE_S", 0.0)
    vol = _declared(tmp_path / "v.h5", 8, 8)
    assert cli.main(["detect", str(vol), "-o", str(tmp_path / "s.h5")]) == 0
    err = capsys.readouterr().err
    assert f"auralize detect: note: {vol}: " in err and "of data to read" in err
    assert cli.main(["-q", "detect", str(vol), "-o", str(tmp_path / "t.h5")]) == 0
    assert "of data to read" not in capsys.readouterr().err
    assert cli.main(["info", str(vol)]) == 0  # describing a file is not work
    assert "of data to read" not in capsys.readouterr().err


# --------------------------------------------------------------------------- chunked frames
@pytest.mark.parametrize("check_finite", [False, True], ids=["mask", "error"])
def test_chunked_frames_read_inf_as_the_volume_does(check_finite: bool) -> None:
    from auralize.distributed.chunked import chunked_volume, to_dask
    from auralize.errors import DataError

    a = np.ones((2, 2, 3, 4))
    a[0, 0, 0, 0], a[1, 1, 1, 1], a[1, 0, 0, 0] = np.inf, -np.inf, np.nan
    vol = TimeVolume.from_arrays({"p": a}, times=[0.0, 0.1])
    vol.check_finite = check_finite
    arr = to_dask(vol, "p").compute(scheduler="sync")
    if check_finite:  # read as stored; frame() refuses them
        np.testing.assert_array_equal(arr, a)
        with pytest.raises(DataError, match="NaN/Inf"):
            chunked_volume(vol).frame("p", 0)
        return
    assert not np.isinf(arr).any() and int(np.isnan(arr).sum()) == 3
    for step in range(2):
        np.testing.assert_array_equal(arr[step], vol.frame("p", step))
        np.testing.assert_array_equal(chunked_volume(vol).frame("p", step), vol.frame("p", step))
    assert np.isinf(a).sum() == 2  # the caller's data are not modified
