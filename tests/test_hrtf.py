"""Binaural output: spherical-head model, the order-3 Ambisonic chain, SOFA files.

Physics checks on the whole chain (a plane wave encoded in AmbiX order 3,
decoded with the model's SH-domain filters) beside the direct reference (the
model's HRIR pair of that one direction convolved with the signal).
"""

from __future__ import annotations

import math
from pathlib import Path

import h5py
import numpy as np
import pytest
from scipy.signal import butter, sosfiltfilt, welch

from auralize.emitters import C0
from auralize.errors import FormatError, MissingFileError, ParameterError
from auralize.spatial import ambisonics as A
from auralize.spatial import get_layout, output_stage, pan_gains, synthesis_layout
from auralize.spatial import hrtf as H
from auralize.spatial.layouts import default_hrtf, receivers_of
from auralize.spatial.sofa import read_sofa, write_sofa

RATE = 48000
#: the order-3 chain reproduces interaural phase up to N c / (2π a) ≈ 1.87 kHz:
#: its ITDs are measured below 1.5 kHz
ITD_BAND_HZ = 1500.0
#: the band of the ray (Woodworth) ITD of the model's HRIRs, above the head-shadow
#: filter's corner 2 ω₀ = 2c/a (1.25 kHz), where its group delay has faded
HF_BAND_HZ = (2000.0, 10000.0)
#: the low-frequency limit of the ITD (Kuhn): below 300 Hz (ka < 0.5)
LF_BAND_HZ = 300.0


def unit(az_deg: float, el_deg: float = 0.0) -> np.ndarray:
    a, e = math.radians(az_deg), math.radians(el_deg)
    return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


@pytest.fixture(scope="module")
def model() -> H.HRIRSet:
    return H.spherical_head_hrirs(rate=RATE)


@pytest.fixture(scope="module")
def noise() -> np.ndarray:
    return np.random.default_rng(7).normal(size=RATE // 2)


def chain(sig: np.ndarray, d: np.ndarray, hrirs: H.HRIRSet) -> np.ndarray:
    return H.binaural_from_ambisonics(A.encode(sig, 3, d), 3, hrirs)


def direct(sig: np.ndarray, d: np.ndarray) -> np.ndarray:
    return H.binaural_direct(sig, H.spherical_head_hrirs(d[None], RATE).ir[0])


def itd_s(
    ears: np.ndarray, rate: int = RATE, band: float | tuple[float, float] = ITD_BAND_HZ
) -> float:
    """Lag (s) of the left ear behind the right (> 0: right ear first), by
    cross-correlation of the band (below a frequency, or between two; zero-phase
    Butterworth), to 1/16 sample, within ±1 ms."""
    if isinstance(band, tuple):
        sos = butter(4, band, "bandpass", fs=rate, output="sos")
    else:
        sos = butter(4, band, fs=rate, output="sos")
    lo, ro = sosfiltfilt(sos, ears, axis=-1)
    n, up = lo.size, 16
    cc = np.fft.irfft(np.fft.rfft(lo, 2 * n) * np.conj(np.fft.rfft(ro, 2 * n)), 2 * n * up)
    m = int(up * rate * 1e-3)
    return (int(np.argmax(np.r_[cc[-m:], cc[: m + 1]])) - m) / up / rate


def ild_db(ears: np.ndarray, f_hz: float) -> float:
    """Right minus left ear level (dB) around ``f_hz`` (Welch, 1/3 octave)."""
    f, p = welch(ears, fs=RATE, nperseg=1024)
    band = (f > f_hz * 2 ** (-1 / 6)) & (f < f_hz * 2 ** (1 / 6))
    return float(10 * np.log10(p[1, band].sum() / p[0, band].sum()))


def test_woodworth_itd() -> None:
    a, c = H.HEAD_RADIUS, H.C0
    # ears on the axis: ITD = (a/c)(θ + sin θ) at θ = 90°
    itd = float(H.woodworth_delay(np.pi) - H.woodworth_delay(0.0))
    assert math.isclose(itd, a / c * (math.pi / 2 + 1)) and 0.65e-3 < itd < 0.66e-3
    for th in np.radians([10.0, 40.0, 75.0]):  # Woodworth for a source at θ from the median plane
        itd = float(H.woodworth_delay(np.pi / 2 + th) - H.woodworth_delay(np.pi / 2 - th))
        assert math.isclose(itd, a / c * (th + math.sin(th)), rel_tol=1e-12)


def test_right_source_arrives_first_and_louder(model: H.HRIRSet, noise: np.ndarray) -> None:
    """Woodworth's ITD is the ray (high-frequency) delay: measured above the
    head-shadow filter's corner, the model's ITD of a source at 90° right is
    (a/c)(cos 10° + 4π/9) = 0.607 ms (ears at ±100°), within the required 0.6–0.7 ms
    (0.656 ms for ears at ±90°).  The order-3 chain carries the interaural time
    difference in the band it reproduces (below N c / 2πa ≈ 1.87 kHz, where the
    auditory system uses ITDs): there it equals the model's."""
    d = unit(-90)
    e, ref = chain(noise, d, model), direct(noise, d)
    itd_hf = itd_s(ref, band=HF_BAND_HZ)
    assert 0.60e-3 <= itd_hf <= 0.70e-3
    # below 1.5 kHz the ITD lies between Woodworth's and the sphere's
    # low-frequency limit 3a/c = 0.765 ms (see the next test)
    itd, itd_ref = itd_s(e), itd_s(ref)
    assert 0.60e-3 <= itd <= 0.765e-3 and 0.60e-3 <= itd_ref <= 0.765e-3
    assert abs(itd - itd_ref) < 30e-6
    assert np.sum(e[1] ** 2) > 2 * np.sum(e[0] ** 2)


def test_low_frequency_itd_approaches_kuhn(noise: np.ndarray) -> None:
    """Below ka ≈ 0.5 a rigid sphere's ITD is 3a/c · sin θ (Kuhn, "Model for the
    interaural time differences in the azimuthal plane", JASA 62(1), 1977), 1.5×
    the high-frequency Woodworth ITD at small angles: the model's
    head-shadow filter adds its low-frequency group delay (1 − α(θ)) a / 2c per ear
    (Brown & Duda 1998, §III-A), which brings its ITD below 300 Hz within 10 % of
    Kuhn's limit, above its own high-frequency ITD."""
    a, c = H.HEAD_RADIUS, H.C0
    for az in (90.0, 60.0, 30.0):
        ref = direct(noise, unit(-az))
        kuhn = 3 * a / c * math.sin(math.radians(az))
        lf, hf = itd_s(ref, band=LF_BAND_HZ), itd_s(ref, band=HF_BAND_HZ)
        assert abs(lf / kuhn - 1) < 0.10, (az, lf, kuhn)
        assert lf > 1.05 * hf, (az, lf, hf)


def test_ild_grows_with_frequency(model: H.HRIRSet, noise: np.ndarray) -> None:
    e, ref = chain(noise, unit(-90), model), direct(noise, unit(-90))
    bands = [250.0, 1000.0, 4000.0, 8000.0]
    ild, ild_ref = [ild_db(e, f) for f in bands], [ild_db(ref, f) for f in bands]
    assert np.all(np.diff(ild) > 0) and np.all(np.diff(ild_ref) > 0)
    assert ild[2] >= 10.0 and ild_ref[2] >= 10.0  # 4 kHz
    assert abs(ild[0] - ild_ref[0]) < 1.0 and abs(ild[1] - ild_ref[1]) < 1.5


def test_front_equal_ears_front_back_differ(model: H.HRIRSet, noise: np.ndarray) -> None:
    front, back = chain(noise, unit(0), model), chain(noise, unit(180), model)
    for e in (front, back):
        np.testing.assert_allclose(e[0], e[1], atol=1e-9 * np.max(np.abs(e)))
    f, pf = welch(front[0], fs=RATE, nperseg=1024)
    _, pb = welch(back[0], fs=RATE, nperseg=1024)
    band = (f > 2000) & (f < 10000)
    diff = 10 * np.log10(pf[band] / pb[band])
    assert np.max(np.abs(diff)) > 2.0  # the ears sit behind the interaural axis
    fr, br = direct(noise, unit(0)), direct(noise, unit(180))
    _, pfr = welch(fr[0], fs=RATE, nperseg=1024)
    _, pbr = welch(br[0], fs=RATE, nperseg=1024)
    assert np.mean(10 * np.log10(pfr[band] / pbr[band])) * np.mean(diff) > 0  # same sign


def test_circling_source_smooth_itd(model: H.HRIRSet) -> None:
    """One turn in 2 s: the ITD of 50 ms windows follows the direct model and has no steps."""
    n = 2 * RATE
    sig = np.random.default_rng(3).normal(size=n)
    az = 2 * np.pi * np.arange(n) / n
    d = np.stack([np.cos(az), np.sin(az), np.zeros(n)], 1)
    e = H.BinauralDecoder(model, 3).process(pan_gains(get_layout("ambix3"), d) * sig)
    win = RATE // 20
    itds, ref = [], []
    for k in range(n // win):
        seg = slice(k * win, (k + 1) * win)
        itds.append(itd_s(e[:, seg]))
        mid = float(az[k * win + win // 2])
        ref.append(itd_s(direct(sig[seg], unit(math.degrees(mid)))))
    itds_a, ref_a = np.array(itds), np.array(ref)
    # no steps: window to window (9° of turn) the ITD changes as the direct model's does
    steps = np.diff(itds_a) - np.diff(ref_a)
    assert np.max(np.abs(steps)) < 60e-6
    assert np.max(np.abs(itds_a - ref_a)) < 40e-6
    assert itds_a.min() < -0.6e-3 and itds_a.max() > 0.6e-3  # left and right both reached


def test_blocks_equal_whole_and_resampling(model: H.HRIRSet, noise: np.ndarray) -> None:
    b = A.encode(noise[:6000], 3, unit(37, 20))
    whole = H.BinauralDecoder(model, 3).process(b)
    dec = H.BinauralDecoder(model, 3, block=500)
    parts = np.concatenate([dec.process(b[:, s : s + 1234]) for s in range(0, 6000, 1234)], 1)
    np.testing.assert_allclose(parts, whole, atol=1e-6 * np.max(np.abs(whole)))
    np.testing.assert_allclose(whole, H.binaural_from_ambisonics(b, 3, model), atol=1e-12)
    d44 = H.BinauralDecoder(model, 3, rate=44100)
    assert d44.rate == 44100 and d44.hrirs.meta["resampled_from_hz"] == RATE
    e = d44.process(A.encode(noise, 3, unit(-90)))
    assert 0.60e-3 < itd_s(e, 44100) < 0.765e-3


def test_decoder_symmetries(model: H.HRIRSet) -> None:
    """The model's head is left–right and up–down symmetric: the decoder filters
    only the 10 channels even in z and gets the right ear from the left's filters;
    either way (and for a set without the symmetries) it equals the sum of the 32
    convolutions."""
    from scipy.signal import oaconvolve

    x = np.random.default_rng(5).normal(size=(16, 3000))
    dec = H.BinauralDecoder(model, 3)
    assert dec.mirrored and dec.channels.tolist() == [0, 1, 3, 4, 6, 8, 9, 11, 13, 15]
    lopsided = H.HRIRSet(model.ir * [[[1.0], [1.02]]], model.directions, RATE, model.weights)
    dec2 = H.BinauralDecoder(lopsided, 3)
    assert not dec2.mirrored
    for d in (dec, dec2):
        ref = oaconvolve(x[:, None, :], d.filters, axes=-1).sum(axis=0)[:, : x.shape[1]]
        np.testing.assert_allclose(d.process(x), ref, atol=1e-6 * np.max(np.abs(ref)))


def test_output_stage_and_binaural_layout(noise: np.ndarray) -> None:
    lay = get_layout("binaural")
    assert lay.n_channels == 2 and lay.channel_names == ["L", "R"]
    ears = synthesis_layout(lay)  # the built-in head: two ear receivers
    assert ears.name == "binaural-ears" and ears.n_channels == 8
    assert [r.name for r in receivers_of(ears)] == ["L", "R"]
    assert isinstance(output_stage(lay, RATE).decoder, H.EarDecoder)
    with default_hrtf(H.default_hrirs(RATE)):  # an HRIR set: the AmbiX chain
        assert synthesis_layout(lay).name == "ambix3"
    with pytest.raises(ParameterError, match="synthesis_layout"):
        pan_gains(lay, np.ones((1, 3)))
    st = output_stage("binaural", RATE, hrtf=H.default_hrirs(RATE))
    out = st.process(A.encode(noise[:4800], 3, unit(90)))
    assert out.shape == (2, 4800) and np.sum(out[0] ** 2) > 2 * np.sum(out[1] ** 2)
    assert "spherical-head" in st.describe()["binaural"]["hrtf"]  # type: ignore[index]
    assert output_stage("ring8", RATE).describe() == {}
    same = output_stage("ring8", RATE).process(np.ones((8, 3)))
    np.testing.assert_array_equal(same, np.ones((8, 3)))
    with pytest.raises(ParameterError, match="binaural"):
        output_stage("ring8", RATE, hrtf="x.sofa")


# ------------------------------------------------------------------ SOFA
def fibonacci(k: int) -> np.ndarray:
    i = np.arange(k) + 0.5
    z = 1 - 2 * i / k
    phi = np.pi * (1 + 5**0.5) * i
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], 1)


def write_synthetic_sofa(
    path: Path, *, drop: str = "", receivers: int = 2, conventions: str = "SOFA"
) -> H.HRIRSet:
    """An AES69 SimpleFreeFieldHRIR file (h5py, the standard's variable names and
    attributes) of the spherical-head model at 300 directions, 44.1 kHz."""
    d = fibonacci(300)
    hr = H.spherical_head_hrirs(d, 44100)
    az = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
    el = np.degrees(np.arcsin(d[:, 2]))
    with h5py.File(path, "w") as h:
        h.attrs.update(
            {
                "Conventions": conventions,
                "Version": "2.1",
                "SOFAConventions": "SimpleFreeFieldHRIR",
                "SOFAConventionsVersion": "1.0",
                "DataType": "FIR",
                "RoomType": "free field",
                "Title": "synthetic",
                "License": "CC0-1.0",
            }
        )
        v = {
            "Data.IR": (hr.ir[:, :receivers], {}),
            "Data.SamplingRate": (np.array([44100.0]), {"Units": "hertz"}),
            "Data.Delay": (np.zeros((1, 2)), {}),
            "SourcePosition": (
                np.stack([az, el, 1.5 * np.ones(300)], 1),
                {"Type": "spherical", "Units": "degree, degree, metre"},
            ),
            "ListenerPosition": (np.zeros((1, 3)), {"Type": "cartesian", "Units": "metre"}),
            "ListenerView": (np.array([[1.0, 0, 0]]), {"Type": "cartesian", "Units": "metre"}),
            "ListenerUp": (np.array([[0, 0, 1.0]]), {"Type": "cartesian", "Units": "metre"}),
        }
        for name, (data, attrs) in v.items():
            if name == drop:
                continue
            ds = h.create_dataset(name, data=data)
            ds.attrs.update(attrs)
    return hr


def test_read_synthetic_sofa_and_use_it(tmp_path: Path, noise: np.ndarray) -> None:
    p = tmp_path / "head.sofa"
    hr = write_synthetic_sofa(p)
    s = read_sofa(p)
    assert s.rate == 44100 and s.ir.shape == hr.ir.shape and s.weights is None
    np.testing.assert_allclose(s.ir, hr.ir)
    np.testing.assert_allclose(s.directions, hr.directions, atol=1e-12)
    assert s.meta["conventions"] == "SimpleFreeFieldHRIR" and s.meta["license"] == "CC0-1.0"
    # used: binaural output at 48 kHz through the order-3 chain
    st = output_stage("binaural", RATE, hrtf=p)
    e = st.process(A.encode(noise, 3, unit(-90)))
    assert 0.60e-3 < itd_s(e) < 0.765e-3 and ild_db(e, 4000.0) > 10.0


def test_sofa_listener_view_and_delay(tmp_path: Path) -> None:
    p = tmp_path / "turned.sofa"
    write_synthetic_sofa(p)
    with h5py.File(p, "r+") as h:
        h["ListenerView"][...] = np.array([[0.0, 1.0, 0.0]])  # listener faces +y (source left)
        h["Data.Delay"][...] = np.array([[3.0, 3.0]])
    s = read_sofa(p)
    ref = read_sofa(tmp_path / "turned.sofa")
    assert s.n_taps == ref.n_taps
    # a source at +y (azimuth 90° in the file) is straight ahead of this listener
    k = int(np.argmax(s.directions[:, 0]))
    d_file = fibonacci(300)[k]
    assert d_file[1] > 0.99
    plain = H.spherical_head_hrirs(fibonacci(300), 44100)
    np.testing.assert_allclose(
        s.ir[k, :, 3 : plain.n_taps], plain.ir[k, :, : plain.n_taps - 3], atol=1e-9
    )


def test_write_sofa_roundtrip(tmp_path: Path) -> None:
    hr = H.spherical_head_hrirs(fibonacci(40), 32000)
    p = write_sofa(tmp_path / "model.sofa", hr)
    s = read_sofa(p)
    np.testing.assert_allclose(s.ir, hr.ir)
    np.testing.assert_allclose(s.directions, hr.directions, atol=1e-12)
    with h5py.File(p, "r") as h:  # netCDF-4 dimensions are attached
        assert h["Data.IR"].dims[0][0].name == "/M"
    assert [q.name for q in tmp_path.iterdir()] == ["model.sofa"]


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"drop": "Data.IR"}, "'Data.IR' is missing"),
        ({"drop": "SourcePosition"}, "'SourcePosition' is missing"),
        ({"drop": "Data.SamplingRate"}, "'Data.SamplingRate' is missing"),
        ({"receivers": 1}, r"Data.IR must be \(M, R=2, N\).*\(300, 1,"),
        ({"conventions": "CF-1.6"}, "'Conventions' is 'CF-1.6', expected 'SOFA'"),
    ],
)
def test_malformed_sofa(tmp_path: Path, kw: dict, match: str) -> None:  # type: ignore[type-arg]
    p = tmp_path / "bad.sofa"
    write_synthetic_sofa(p, **kw)
    with pytest.raises(FormatError, match=match) as ei:
        read_sofa(p)
    assert str(p) in str(ei.value)


def test_not_sofa_files(tmp_path: Path) -> None:
    with pytest.raises(MissingFileError, match="does not exist"):
        read_sofa(tmp_path / "none.sofa")
    txt = tmp_path / "text.sofa"
    txt.write_text("hello")
    with pytest.raises(FormatError, match="not a SOFA file"):
        read_sofa(txt)


def test_emitters_rendered_binaurally_end_to_end() -> None:
    """The engine's reference renderer pans to the binaural layout's AmbiX
    intermediate; the output stage gives ears: an emitter on the listener's right
    arrives first and louder at the right ear."""
    from auralize.emitters import Emitters
    from auralize.emitters.engine import render_emitters
    from auralize.listener import ListenerPath

    rate = 16000
    sig = np.random.default_rng(5).normal(size=(1, rate // 4))
    path = ListenerPath.point((0, 0, 0), duration=0.25)  # forward +y, up +z: right is +x
    em = Emitters(sig, rate, np.array([[4.0, 0.0, 0.0]]))
    amb = render_emitters(
        em, path, rate=rate, layout=synthesis_layout("binaural"), backend="reference"
    ).audio
    ears = output_stage("binaural", rate).process(amb)
    assert ears.shape == (2, amb.shape[1])
    assert np.sum(ears[1] ** 2) > 2 * np.sum(ears[0] ** 2)
    assert 0.60e-3 < itd_s(ears, rate) < 0.8e-3


def test_immersive_layouts_in_the_speaker_kernels() -> None:
    """The synthesis kernel encodes AmbiX itself (a source straight ahead, +y for a
    static listener: X = W, the other first-order channels silent); binaural, which
    needs the output stage after the sum, is refused clearly instead of writing W
    only; speaker azimuths stay undefined for immersive layouts."""
    from auralize.emitters.synthesis import render_tracks
    from auralize.listener import ListenerPath
    from auralize.sources import SourceTracks

    tr = SourceTracks(
        np.array([[0, 1.0, 0]]),
        np.sin(np.arange(8.0))[None, :],
        np.array([0.05]),
        np.arange(8) / 100.0,
    )
    a = render_tracks(tr, ListenerPath.point((0, 0, 0), duration=0.05), layout="ambix3").audio
    assert a.shape[0] == 16 and np.max(np.abs(a[0])) > 0
    np.testing.assert_allclose(a[3], a[0], atol=1e-12 * np.max(np.abs(a[0])))
    assert np.max(np.abs(a[1:3])) <= 1e-12 * np.max(np.abs(a[0]))
    with pytest.raises(ParameterError, match="synthesis_layout"):
        render_tracks(tr, ListenerPath.point((0, 0, 0), duration=0.05), layout="binaural")
    for name in ("ambix3", "binaural"):
        with pytest.raises(ParameterError, match="no speaker azimuths"):
            get_layout(name).panning_arrays()


def test_sofa_cartesian_positions(tmp_path: Path) -> None:
    p = tmp_path / "cart.sofa"
    hr = write_synthetic_sofa(p)
    with h5py.File(p, "r+") as h:
        del h["SourcePosition"]
        ds = h.create_dataset("SourcePosition", data=2.0 * hr.directions)
        ds.attrs.update({"Type": "cartesian", "Units": "metre"})
        h["ListenerPosition"][...] = np.array([[0.0, 0.0, 0.0]])
    s = read_sofa(p)
    np.testing.assert_allclose(s.directions, hr.directions, atol=1e-12)
    with h5py.File(p, "r+") as h:
        h["SourcePosition"].attrs["Type"] = "polar"
    with pytest.raises(FormatError, match="SourcePosition has Type='polar'"):
        read_sofa(p)


# ------------------------------------------------------------------ ears as receivers
def ears_of(
    az_deg: float, el_deg: float = 0.0, *, n: int = RATE // 2, backend: str = "auto"
) -> tuple[np.ndarray, np.ndarray]:
    """The default binaural render (two ear receivers) of white noise from a static
    emitter 30 m away at (az, el) of a listener facing +y, and the direct model's
    ears of that direction (the same delay D/c and 1/D applied to the signal).

    The noise is emitted at half the output rate, so that the engine upsamples it
    band-limited (no high-frequency loss of interpolation); the distance is a whole
    number of output samples of travel."""
    from scipy.signal import resample_poly

    from auralize.emitters import Emitters, render_emitters
    from auralize.listener import ListenerPath

    sig = np.random.default_rng(11).normal(size=n // 2)
    k = 4200
    dist = k * C0 / RATE
    d = unit(az_deg, el_deg)  # listener frame (forward, left, up) -> world (-left, forward, up)
    world = dist * np.array([-d[1], d[0], d[2]])
    em = Emitters(sig[None], RATE // 2, world[None])
    out = render_emitters(
        em,
        ListenerPath.point((0, 0, 0), duration=n / RATE),
        rate=RATE,
        layout="binaural",
        backend=backend,
    ).audio
    up = resample_poly(sig, 2, 1)
    ref = direct(np.r_[np.zeros(k), up[: n - k]] / dist, d)
    return out[:, k + 500 :], ref[:, k + 500 :]


def test_ear_receivers_right_source_itd_ild() -> None:
    """The default binaural output renders each ear as a receiver with its own
    retarded time: for a source 90° right the ITD is Woodworth's at every
    frequency, not only below the order-3 limit (0.6–0.7 ms broadband and
    2–10 kHz; the model's own 0.612/0.625 ms), the right ear is louder by
    ≥ 10 dB at 4 kHz and the ILD grows with frequency."""
    e, ref = ears_of(-90.0)
    full = (20.0, 11000.0)
    for band in (full, HF_BAND_HZ):
        itd, itd_ref = itd_s(e, band=band), itd_s(ref, band=band)
        assert 0.60e-3 <= itd <= 0.70e-3, (band, itd)
        assert abs(itd - itd_ref) < 25e-6, (band, itd, itd_ref)
    ild = [ild_db(e, f) for f in (250.0, 1000.0, 4000.0, 8000.0)]
    assert np.all(np.diff(ild) > 0) and ild[2] >= 10.0, ild
    assert abs(ild[2] - ild_db(ref, 4000.0)) < 1.0


@pytest.mark.parametrize(
    ("az", "el"),
    [(0.0, 0.0), (30.0, 0.0), (-60.0, 20.0), (135.0, 0.0), (180.0, -30.0), (-120.0, 45.0)],
)
def test_ear_receivers_follow_the_model(az: float, el: float) -> None:
    """Against the model's own HRIR pair of the direction (the same bulk delay):
    third-octave ear levels within 2 dB from 200 Hz to 10 kHz (the largest
    differences are in the shadowed ear near 150° from it, 20 dB down at high
    frequencies), and the ITD below 1.5 kHz and in 2–10 kHz within 40 µs (also
    largest for that ear; at lateral angles the ITD's just-noticeable difference
    is about that)."""
    e, ref = ears_of(az, el)
    f, p = welch(e, fs=RATE, nperseg=2048)
    _, pr = welch(ref, fs=RATE, nperseg=2048)
    for fc in 200.0 * 2 ** (np.arange(17) / 3):
        band = (f > fc * 2 ** (-1 / 6)) & (f < fc * 2 ** (1 / 6))
        lv = 10 * np.log10(p[:, band].sum(axis=1) / pr[:, band].sum(axis=1))
        assert np.all(np.abs(lv) < 2.0), (az, el, fc, lv)
    for band in (ITD_BAND_HZ, HF_BAND_HZ):
        assert abs(itd_s(e, band=band) - itd_s(ref, band=band)) < 40e-6, band


def test_ear_receivers_front_equal_back_differs() -> None:
    front, _ = ears_of(0.0)
    back, _ = ears_of(180.0)
    for e in (front, back):
        np.testing.assert_allclose(e[0], e[1], atol=1e-6 * np.max(np.abs(e)))
    f, pf = welch(front[0], fs=RATE, nperseg=1024)
    _, pb = welch(back[0], fs=RATE, nperseg=1024)
    band = (f > 2000) & (f < 10000)
    assert np.max(np.abs(10 * np.log10(pf[band] / pb[band]))) > 2.0


def test_ear_receivers_circling_source_and_turning_head() -> None:
    """A source circling the listener (one turn in 2 s, 5 m away) gives a smooth ITD
    track that follows the model; a head turning under a still source gives the
    same track (the ears turn with the listener's forward vector)."""
    from auralize.emitters import Emitters, render_emitters
    from auralize.listener import ListenerPath

    n, r = 2 * RATE, 5.0
    sig = np.random.default_rng(3).normal(size=n)
    k = 400  # positions at 200 Hz
    tk = np.arange(k + 1) / 200.0
    az = 2 * np.pi * tk / 2.0
    pos = np.stack([-r * np.sin(az), r * np.cos(az), np.zeros_like(az)], 1)  # az from +y, ccw
    em = Emitters(sig[None], RATE, pos[None], pos_rate=200.0)
    still = ListenerPath.point((0, 0, 0), duration=2.0)
    circling = render_emitters(em, still, rate=RATE, layout="binaural").audio
    # the head turns clockwise at the same rate; the source stays straight ahead
    fwd = np.stack([np.sin(az), np.cos(az), np.zeros_like(az)], 1)
    turning = ListenerPath(tk, np.zeros((k + 1, 3)), fwd, np.tile([0.0, 0, 1], (k + 1, 1)))
    em2 = Emitters(sig[None], RATE, np.array([[0.0, r, 0.0]]))
    turned = render_emitters(em2, turning, rate=RATE, layout="binaural").audio
    win = RATE // 20
    lag = int(round(r / C0 * RATE))
    # the circling source's direction is that of its emission, the turning head's
    # that of the arrival (one travel time r/c later); the ITDs below 1.5 kHz and
    # of the ray regime (2–10 kHz)
    for e, late, band in (
        (circling, 0, ITD_BAND_HZ),
        (turned, lag, ITD_BAND_HZ),
        (circling, 0, HF_BAND_HZ),
        (turned, lag, HF_BAND_HZ),
    ):
        itds, ref = [], []
        for w in range(1, n // win - 1):
            seg = slice(w * win + lag, (w + 1) * win + lag)
            itds.append(itd_s(e[:, seg], band=band))
            mid = 360.0 * (w * win + win / 2 + late) / n
            ref.append(itd_s(direct(sig[w * win : (w + 1) * win], unit(mid)), band=band))
        itds_a, ref_a = np.array(itds), np.array(ref)
        assert np.max(np.abs(np.diff(itds_a) - np.diff(ref_a))) < 60e-6
        assert np.max(np.abs(itds_a - ref_a)) < 50e-6
        assert itds_a.min() < -0.6e-3 and itds_a.max() > 0.6e-3


def test_ear_receivers_delay_and_distance() -> None:
    """Each ear hears the emitter at its own distance: a click 10 m to the right
    reaches the right ear (10 − a·sin 100°)/c + the bulk delay after emission, with
    the 1/D level of that distance at low frequency."""
    from auralize.emitters import Emitters, render_emitters
    from auralize.listener import ListenerPath

    sig = np.zeros(RATE // 10)
    sig[100] = 1.0  # at 100 / RATE s
    em = Emitters(sig[None], RATE, np.array([[10.0, 0.0, 0.0]]))
    out = render_emitters(
        em,
        ListenerPath.point((0, 0, 0), duration=0.1),
        rate=RATE,
        layout="binaural",
        backend="reference",
    ).audio
    _, bulk = H.ear_filters(RATE)
    a = H.HEAD_RADIUS
    d_right = math.hypot(10.0 - a * math.sin(math.radians(100)), a * math.cos(math.radians(100)))
    onset = int(np.argmax(np.abs(out[1]) > 0.1 * np.max(np.abs(out[1]))))
    assert abs(onset / RATE - (100 / RATE + d_right / C0 + bulk)) < 3 / RATE
    # at 0 Hz the head casts no shadow: the sum of each ear's response is its 1/D
    d_left = math.hypot(10.0 + a * math.sin(math.radians(100)), a * math.cos(math.radians(100)))
    assert math.isclose(out[1].sum(), 1.0 / d_right, rel_tol=0.005)
    assert math.isclose(out[0].sum(), 1.0 / d_left, rel_tol=0.005)


def test_ear_receivers_keep_the_doppler_shift() -> None:
    """A 1 kHz emitter passing the listener at 40 m/s, 5 m to its right: in each ear the
    tone is heard at f₀ c / (c − v·û) of the emission (û from the emitter to that ear),
    measured within 0.5 % on 40 ms windows while it approaches and recedes."""
    from auralize.emitters import Emitters, render_emitters
    from auralize.listener import ListenerPath

    f0, v, y0, dur = 1000.0, 40.0, 5.0, 1.0
    t_e = np.arange(int(dur * RATE)) / RATE
    tk = np.arange(101) / 100.0
    pos = np.stack([np.full_like(tk, y0), -20.0 + v * tk, np.zeros_like(tk)], 1)  # x right, y ahead
    em = Emitters(np.sin(2 * np.pi * f0 * t_e)[None], RATE, pos[None], pos_rate=100.0)
    out = render_emitters(
        em, ListenerPath.point((0, 0, 0), duration=dur), rate=RATE, layout="binaural"
    ).audio
    win = int(0.04 * RATE)
    for t_emit in (0.2, 0.8):  # approaching, receding
        src = np.array([y0, -20.0 + v * t_emit, 0.0])
        for ear, side in ((0, +1.0), (1, -1.0)):  # left ear at -x (listener faces +y)
            e = np.array(
                [
                    -side * H.HEAD_RADIUS * math.sin(math.radians(100)),
                    H.HEAD_RADIUS * math.cos(math.radians(100)),
                    0.0,
                ]
            )
            d = src - e
            u = d / np.linalg.norm(d)  # from the ear to the emitter
            f_exp = f0 * C0 / (C0 + v * u[1])  # emitter velocity (0, v, 0) away along u
            t_arr = t_emit + np.linalg.norm(d) / C0
            i0 = int(t_arr * RATE) - win // 2
            seg = out[ear, i0 : i0 + win] * np.hanning(win)
            spec = np.abs(np.fft.rfft(seg, 16 * win))
            k = int(np.argmax(spec))
            a, b, c = np.log(spec[k - 1 : k + 2])
            f_meas = (k + 0.5 * (a - c) / (a - 2 * b + c)) * RATE / (16 * win)
            assert abs(f_meas / f_exp - 1) < 0.005, (t_emit, ear, f_meas, f_exp)
