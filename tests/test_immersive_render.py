"""Binaural and AmbiX output end to end: the synthesis kernels' AmbiX gains against the
numpy reference, one output stage after the sum (offline, block-wise and live), and the
command line (``--layout binaural|ambix3``, ``--hrtf FILE.sofa``)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
from scipy.signal import butter, sosfiltfilt

from auralize.cli import main
from auralize.emitters import Emitters
from auralize.emitters._kernels.gains import _gains
from auralize.emitters.engine import BlockRenderer, render_emitters, render_sound
from auralize.emitters.synthesis import pan_table, panning_arrays, render_reference
from auralize.emitters.synthesis import render_tracks as synth_render
from auralize.emitters.timbre import render_timbre
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.pipeline import render
from auralize.spatial import get_layout
from auralize.spatial import hrtf as H
from auralize.spatial.ambisonics import sh_gains
from auralize.spatial.sofa import write_sofa

ROOT = Path(__file__).parents[1]
RATE = 44100


def itd_s(ears: np.ndarray, rate: int = RATE, band: float | tuple[float, float] = 1500.0) -> float:
    """Lag (s) of the left ear behind the right (> 0: right ear first), by
    cross-correlation below 1.5 kHz (or in ``band``), to 1/16 sample, within
    ±1 ms (as test_hrtf)."""
    kind = "bandpass" if isinstance(band, tuple) else "lowpass"
    lo, ro = sosfiltfilt(butter(4, band, kind, fs=rate, output="sos"), ears, axis=-1)
    n, up = lo.size, 16
    cc = np.fft.irfft(np.fft.rfft(lo, 2 * n) * np.conj(np.fft.rfft(ro, 2 * n)), 2 * n * up)
    m = int(up * rate * 1e-3)
    return (int(np.argmax(np.r_[cc[-m:], cc[: m + 1]])) - m) / up / rate


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def test_kernel_sh_gains_equal_ambisonics() -> None:
    """The kernel's recurrence (no trigonometry) is the AmbiX encoding, for any
    head orientation, the poles and a zero vector included."""
    rng = np.random.default_rng(3)
    d = np.vstack([rng.normal(size=(40, 3)), [[0, 0, 1.0], [0, 0, -2.0], [0, 0, 0]]])
    f = np.array([0.6, 0.8, 0.0])
    u = np.array([0.0, 0.0, 1.0])
    left = np.cross(u, f)
    local = np.stack([d @ f, d @ left, d @ u], axis=1)
    for name in ("ambix1", "ambix2", "ambix3"):
        lay = get_layout(name)
        az, ch = panning_arrays(lay)
        tab = pan_table(lay, az)
        out = np.zeros(lay.n_channels)
        got = []
        for v in d:
            _gains((v[0], v[1], v[2]), (*f, *u), az, ch, False, tab, out)
            got.append(out.copy())
        np.testing.assert_allclose(np.array(got).T, sh_gains(lay.meta["order"], local), atol=1e-13)


@pytest.mark.parametrize("layout", ["ambix1", "ambix3"])
def test_field_render_to_ambix_equals_reference(mono_tracks, mono_params, layout) -> None:  # type: ignore[no-untyped-def]
    """A compact pulsating source heard along a curved, turning path with captures
    every 2 ms: the kernel's AmbiX render is the sample-by-sample reference within
    the synthesis tests' tolerance for panned layouts (gains linear within a piece)."""
    c = mono_params.center
    path = ListenerPath.orbit(c, radius=2.2, duration=0.05, turns=0.15, rate_hz=500.0)
    sub = type(mono_tracks)(
        positions=mono_tracks.positions[::5],
        q=mono_tracks.q[::5],
        radius=mono_tracks.radius[::5],
        times=mono_tracks.times,
    )
    fast = synth_render(sub, path, rate=RATE, layout=layout)
    ref = render_reference(sub, path, rate=RATE, layout=layout)
    assert fast.audio.shape == ref.shape == (get_layout(layout).n_channels, round(0.05 * RATE))
    assert fast.layout.name == layout
    assert _rel(fast.audio, ref) < 5e-3
    # consecutive short windows join without seams
    n = fast.audio.shape[1]
    parts = [
        synth_render(
            sub, path, rate=RATE, layout=layout, start=a / RATE, duration=min(700, n - a) / RATE
        ).audio
        for a in range(0, n, 700)
    ]
    assert np.max(np.abs(np.concatenate(parts, axis=1) - fast.audio)) <= 1e-9 * np.max(
        np.abs(fast.audio)
    )


def test_synthesis_render_refuses_binaural_clearly(mono_tracks) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ParameterError, match="synthesis_layout"):
        synth_render(mono_tracks, ListenerPath.point((0, 0, 0), duration=0.01), layout="binaural")


def _orbit_emitters() -> tuple[Emitters, ListenerPath]:
    rng = np.random.default_rng(5)
    n = int(0.3 * RATE)
    t = np.arange(n) / RATE
    sig = np.stack([np.sin(2 * np.pi * f * t) for f in (180.0, 420.0, 650.0)]) * np.hanning(n)
    pos = np.array([[4.0, 1.0, 0.5], [-2.0, 5.0, -1.0], [1.0, -6.0, 2.0]])
    m = 40
    vel = rng.uniform(-30, 30, size=(3, 3))
    traj = pos[:, None, :] + vel[:, None, :] * (np.arange(m) / m * 0.3 - 0.1)[None, :, None]
    em = Emitters(sig, RATE, traj, t0=-0.08, pos_rate=m / 0.3, radius=0.3)
    p = ListenerPath.orbit((0.5, 0.0, 0.0), radius=2.0, duration=0.2, turns=0.2, height=0.3)
    return em, p


def test_emitters_fast_backend_ambix3_equals_reference() -> None:
    em, path = _orbit_emitters()
    fast = render_emitters(em, path, rate=RATE, layout="ambix3")
    ref = render_emitters(em, path, rate=RATE, layout="ambix3", backend="reference")
    assert fast.audio.shape == ref.audio.shape == (16, int(0.2 * RATE))
    assert _rel(fast.audio, ref.audio) < 1.5e-3  # test_emitters' tolerance for panned layouts


def test_scene_binaural_is_the_stage_of_the_summed_ambix_render() -> None:
    """Parts are summed in the ears' channels (each ear a receiver) and filtered
    once: the binaural render equals the ear decoder applied to the render of the
    ear layout; with an HRIR set, the binaural decoder applied to the ambix3 render;
    blocks (and a seek) equal it."""
    em, path = _orbit_emitters()
    ears = render_sound(em, path, rate=RATE, layout=H.ear_layout())
    b = render_sound(em, path, rate=RATE, layout="binaural")
    assert b.layout.name == "binaural" and b.audio.shape == (2, ears.audio.shape[1])
    assert "ears" in b.meta["binaural"]["receivers"] and "spherical-head" in str(
        b.meta["binaural"]["hrtf"]
    )
    assert ears.audio.shape[0] == 8 and _rel(b.audio, H.EarDecoder(RATE).process(ears.audio)) < 1e-5
    amb = render_sound(em, path, rate=RATE, layout="ambix3")
    sh = render_sound(em, path, rate=RATE, layout="binaural", hrtf=H.default_hrirs(RATE))
    assert sh.meta["binaural"]["intermediate"] == "ambix3"
    ref = H.BinauralDecoder(H.default_hrirs(RATE), 3).process(amb.audio)
    assert _rel(sh.audio, ref) < 1e-5
    br = BlockRenderer(em, path, rate=RATE, layout="binaural", block=2205)
    on = np.concatenate([br.block(i) for i in range(br.n_blocks)], axis=1)
    assert on.shape == b.audio.shape and _rel(on, b.audio) < 1e-5
    assert _rel(br.render_range(3000, 1500), b.audio[:, 3000:4500]) < 1e-5
    # a single emitter's render_emitters applies the same stage
    one = render_emitters(em, path, rate=RATE, layout="binaural")
    assert _rel(one.audio, b.audio) < 1e-5


SCENE = """
import numpy as np
from auralize.listener import ListenerPath
from auralize.sources import SourceTracks

def scene():
    fk = 4000.0
    t = np.arange(int(2.4 * fk)) / fk
    q = np.stack([np.sin(2 * np.pi * 220 * t), 0.5 * np.sin(2 * np.pi * 330 * t + 1.0)])
    tracks = SourceTracks(np.array([[4.0, 0.5, 0.0], [-1.0, 3.0, 1.0]]), q,
                          np.array([0.1, 0.1]), t)
    path = ListenerPath.orbit((0, 0, 0), radius=1.0, duration=2.0, turns=0.5, face="forward")
    return tracks, path
"""

PLAYER = """
import json
from auralize.audio.live import play
from auralize.pipeline import render
tracks, path = scene()
blocks = render(tracks, path, layout="binaural", block=2205, highpass_hz=0.0)
r = play(blocks, device="auralize_file2", gain=2.0, wait_s=1.0)
print(json.dumps(r.as_dict()))
"""


def _scene():  # type: ignore[no-untyped-def]
    ns: dict[str, object] = {}
    exec(SCENE, ns)
    return ns["scene"]()  # type: ignore[operator]


def test_block_synthesis_binaural_equals_offline() -> None:
    tracks, path = _scene()
    off = render_timbre(tracks, path, layout="binaural", highpass_hz=0.0)
    blocks = render(tracks, path, layout="binaural", block=2205, highpass_hz=0.0)
    assert blocks.layout.name == "binaural"
    # the built-in head: each ear a receiver with its four zonal harmonics (synthesized by
    # the engine's BlockRenderer of the whole sound: without a high-pass none is split off)
    lay = blocks.models.synthesis_layout
    assert lay.name == "binaural-ears" and lay.n_channels == 8
    on = np.concatenate([blocks.block(i) for i in range(blocks.n_blocks)], axis=1)
    assert on.shape == off.audio.shape == (2, 88200)
    assert _rel(on, off.audio) < 1e-5
    assert _rel(blocks.block(17), off.audio[:, 17 * 2205 : 18 * 2205]) < 1e-5  # after a seek
    # with the output high-pass (as `auralize play` plays): the offline render's samples too
    filtered = render(tracks, path, layout="binaural")
    blocks = render(tracks, path, layout="binaural", block=2205)
    on = np.concatenate([blocks.block(i) for i in range(blocks.n_blocks)], axis=1)
    assert _rel(on, filtered.audio) < 1e-5 and _rel(filtered.audio, off.audio) > 1e-3


def test_live_binaural_on_file_backed_alsa_device(tmp_path) -> None:  # type: ignore[no-untyped-def]
    cfg = tmp_path / "cfg"
    (cfg / "alsa").mkdir(parents=True)
    out2 = tmp_path / "dev2.raw"
    (cfg / "alsa" / "asoundrc").write_text(
        textwrap.dedent(f"""
        pcm.auralize_file2 {{
            type file
            slave.pcm "null"
            file "{out2}"
            format "raw"
        }}
        """)
    )
    env = {**os.environ, "XDG_CONFIG_HOME": str(cfg), "PYTHONPATH": str(ROOT)}
    code = textwrap.dedent(SCENE) + textwrap.dedent(PLAYER)
    res = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=180
    )
    assert res.returncode == 0, res.stderr[-3000:]
    r = json.loads(res.stdout.strip().splitlines()[-1])
    assert r["channels"] == 2 and r["layout"] == "binaural" and r["blocks"] == 40
    assert r["underruns"] == 0 and r["device_underflows"] == 0
    tracks, path = _scene()
    ref = 2.0 * render_timbre(tracks, path, layout="binaural", highpass_hz=0.0).audio
    dev = np.fromfile(out2, dtype="<f4").reshape(-1, 2).T.astype(np.float64)
    # the device's delay: first samples above the float32 FFT's rounding (~1e-7 of the peak,
    # spread over a whole block before the onset)
    on = 1e-5 * np.max(np.abs(ref))
    lag = int(np.argmax(np.any(np.abs(dev) > on, axis=0))) - int(
        np.argmax(np.any(np.abs(ref) > on, axis=0))
    )
    assert 0 <= lag <= RATE
    d = dev[:, lag : lag + ref.shape[1]]
    assert d.shape == ref.shape and np.max(np.abs(d - ref)) <= 1e-4 * np.max(np.abs(ref))


# ----------------------------------------------------------------- command line
def _fibonacci(n: int) -> np.ndarray:
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    a = math.pi * (1 + 5**0.5) * k
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(a), r * np.sin(a), z], axis=1)


def itd_phat_s(ears: np.ndarray, rate: int = RATE) -> float:
    """As :func:`itd_s` with the phase transform (every frequency from 50 Hz to
    1.5 kHz weighted alike): the ITD a white noise would give, for any spectrum."""
    n, up = ears.shape[1], 16
    x = np.fft.rfft(ears[0], 2 * n) * np.conj(np.fft.rfft(ears[1], 2 * n))
    f = np.fft.rfftfreq(2 * n, 1.0 / rate)
    x = x / np.maximum(np.abs(x), 1e-300) * ((f > 50.0) & (f < 1500.0))
    cc = np.fft.irfft(x, 2 * n * up)
    m = int(up * rate * 1e-3)
    return (int(np.argmax(np.r_[cc[-m:], cc[: m + 1]])) - m) / up / rate


def ild_db(ears: np.ndarray, f_hz: float) -> float:
    """Right minus left ear level (dB) in the third octave around ``f_hz``."""
    from scipy.signal import welch

    f, p = welch(ears, fs=RATE, nperseg=1024)
    band = (f > f_hz * 2 ** (-1 / 6)) & (f < f_hz * 2 ** (1 / 6))
    return float(10 * np.log10(p[1, band].sum() / p[0, band].sum()))


def _cli_render(tmp_path: Path, out: Path, *extra: str) -> int:
    """The 16³ explosion (centre (7.5, 7.5, 7.5), 15 m wide) heard from 60 m along +x,
    facing -y: a compact source at 90° to the right; ``extended`` timbre (broadband)."""
    p = tmp_path / "right.csv"
    p.write_text(
        "t,x,y,z,fx,fy,fz,ux,uy,uz\n"
        + "".join(f"{t},67.5,7.5,7.5,0,-1,0,0,0,1\n" for t in (0.0, 1.0))
    )
    return main(
        [
            "render",
            "dataset:explosion",
            "--size",
            "16",
            "--path",
            str(p),
            "--timbre",
            "extended",
            "-o",
            str(out),
            *extra,
        ]
    )


def test_cli_binaural_right_source_and_sofa(tmp_path: Path) -> None:
    out = tmp_path / "b.wav"
    assert _cli_render(tmp_path, out, "--layout", "binaural") == 0
    ears, rate = sf.read(out, always_2d=True)
    ears = ears.T
    side = json.loads(Path(str(out) + ".json").read_text())
    assert ears.shape == (2, RATE) and rate == RATE and side["layout"]["name"] == "binaural"
    assert "spherical-head" in side["binaural"]["hrtf"] and "ears" in side["binaural"]["receivers"]
    # right ear first and louder, more so at high frequencies (head shadow).  The file
    # starts as the nearest sources' sound arrives, already rising, in both ears at
    # once: the first 50 ms are left out of the measures.  Woodworth's (ray) ITD for
    # the 8.75 cm head, 0.6–0.7 ms, above 2 kHz; below 1.5 kHz the sphere's larger
    # one (Kuhn's 3a/c = 0.765 ms)
    ears = ears[:, RATE // 20 :]
    assert 0.60e-3 <= itd_s(ears, band=(2000.0, 10000.0)) <= 0.70e-3
    itd = itd_phat_s(ears)
    assert 0.65e-3 <= itd <= 0.80e-3, itd
    assert 0.0 < ild_db(ears, 500.0) < ild_db(ears, 4000.0) and ild_db(ears, 4000.0) >= 10.0
    # SOFA files via --hrtf (the AmbiX chain): a bigger head (11 cm) gives a larger ITD
    # than the 8.75 cm one, in proportion; the file is named in the sidecar
    itds = []
    for radius in (0.0875, 0.11):
        sofa = tmp_path / f"head_{radius * 1000:.0f}mm.sofa"
        write_sofa(sofa, H.spherical_head_hrirs(_fibonacci(300), RATE, radius=radius))
        out2 = tmp_path / f"b_{radius * 1000:.0f}.wav"
        assert _cli_render(tmp_path, out2, "--layout", "binaural", "--hrtf", str(sofa)) == 0
        side2 = json.loads(Path(str(out2) + ".json").read_text())
        assert sofa.name in str(side2["binaural"]["hrtf"])
        assert side2["binaural"]["intermediate"] == "ambix3"
        itds.append(itd_phat_s(sf.read(out2, always_2d=True)[0].T))
    assert itds[1] == pytest.approx(itds[0] * 0.11 / 0.0875, rel=0.08), itds
    # AmbiX order 3 of the same scene: 16 channels, SN3D: Y = -W (right), Z = X = 0
    out3 = tmp_path / "a.wav"
    assert _cli_render(tmp_path, out3, "--layout", "ambix3") == 0
    amb = sf.read(out3, always_2d=True)[0].T
    side3 = json.loads(Path(str(out3) + ".json").read_text())
    assert amb.shape[0] == 16 and side3["layout"]["meta"]["normalisation"] == "SN3D"
    g = amb @ amb[0] / (amb[0] @ amb[0])  # each channel's gain relative to W
    # the whole field is heard: the sound comes from where the explosion changes, inside
    # the data's box, which is 15 m wide at 60 m: Z and X within its half-width, 7.5/60
    np.testing.assert_allclose(g[:2], [1.0, -1.0], atol=0.03)
    assert np.all(np.abs(g[2:4]) <= 7.5 / 60 + 0.01), g[:4]


def test_cli_bad_sofa_exits_3_and_writes_nothing(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    bad = tmp_path / "bad.sofa"
    bad.write_bytes(b"not an HDF5 file at all")
    out = tmp_path / "x.wav"
    code = _cli_render(tmp_path, out, "--layout", "binaural", "--hrtf", str(bad))
    err = capsys.readouterr().err.strip()
    assert code == 3 and len(err.splitlines()) == 1 and "bad.sofa" in err and "SOFA" in err
    assert not out.exists() and not Path(str(out) + ".json").exists()
    assert (
        _cli_render(tmp_path, out, "--layout", "binaural", "--hrtf", str(tmp_path / "missing.sofa"))
        == 3
    )
    assert _cli_render(tmp_path, out, "--layout", "ring8", "--hrtf", str(bad)) == 2
    assert "binaural only" in capsys.readouterr().err
    assert not out.exists()


def test_flac_of_ambix_warns(tmp_path: Path) -> None:
    from auralize.audio import write_audio

    a = np.random.default_rng(0).normal(size=(16, 4410)) * 0.1
    with pytest.warns(UserWarning, match="ambix1.*FLAC"):
        write_audio(
            tmp_path / "a.flac", a[:4], RATE, sidecar={"layout": get_layout("ambix1").describe()}
        )
    with pytest.raises(ParameterError, match="at most 8 channels"):
        write_audio(tmp_path / "a3.flac", a, RATE, layout="ambix3")
    assert not (tmp_path / "a3.flac").exists()
    with pytest.warns(UserWarning, match="ring8"):
        write_audio(tmp_path / "r.flac", a[:8], RATE, layout="ring8")
    write_audio(tmp_path / "s.flac", a[:6], RATE, layout="5.1")  # a standard mask: no warning


def test_viewer_live_engine_binaural_equals_offline() -> None:
    """The viewer's live engine (the head follows the camera) renders binaural blocks
    through one stage: for a still pose they equal the offline render."""
    from auralize.scene.listening import LiveEngine
    from auralize.sources import SourceTracks

    fk = 4000.0
    t = np.arange(int(0.6 * fk)) / fk
    tr = SourceTracks(
        np.array([[3.0, 0.0, 0.0]]), np.sin(2 * np.pi * 300 * t)[None, :], np.array([0.1]), t
    )
    eng = LiveEngine(tr, layout="binaural", block=2205, loop=False, highpass_hz=0.0)
    assert eng.layout.name == "binaural"
    eng.set_pose([0, 0, 0], [0, 1, 0], [0, 0, 1])  # the source at +x: to the right
    on = np.concatenate([eng.next_block() for _ in range(10)], axis=1)
    # (the live clock skips the travel time to the source, as a render's plan does)
    assert eng.lead == pytest.approx(3.0 / 343.0)
    off = render_timbre(
        tr,
        ListenerPath.point((0, 0, 0), duration=0.5),
        layout="binaural",
        highpass_hz=0.0,
        lead=eng.lead,
    ).audio
    assert on.shape == off.shape == (2, 22050) and _rel(on, off) < 1e-5
    assert np.sqrt(np.mean(on[1] ** 2)) > np.sqrt(np.mean(on[0] ** 2))


def test_distributed_render_binaural_equals_one_render() -> None:
    """Dask-style blocks × source groups are summed in AmbiX, then filtered once."""
    from auralize.distributed.synth import render_distributed
    from auralize.sources import SourceTracks

    fk = 4000.0
    t = np.arange(int(0.6 * fk)) / fk
    q = np.stack([np.sin(2 * np.pi * 300 * t), np.cos(2 * np.pi * 200 * t)])
    tr = SourceTracks(np.array([[3.0, 0, 0], [0, 4.0, 1]]), q, np.array([0.1, 0.1]), t)
    p = ListenerPath.orbit((0, 0, 0), radius=1.0, duration=0.5, turns=0.3)
    d = render_distributed(
        tr, p, layout="binaural", scheduler="sync", groups=2, block_seconds=0.1, log=None
    )
    one = render_timbre(tr, p, layout="binaural", highpass_hz=0.0)
    assert d.layout.name == "binaural" and "binaural" in d.meta
    assert d.audio.shape == one.audio.shape and _rel(d.audio, one.audio) < 1e-5
