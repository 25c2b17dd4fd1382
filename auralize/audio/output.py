"""Sound files and sound devices: the only module that touches them.

Audio arrays are ``(n_channels, n_samples)``; they are transposed only here
(and in :mod:`auralize.audio.live`, at the sounddevice callback).  WAV files are
written by our own writer so that multichannel files carry a
WAVE_FORMAT_EXTENSIBLE header with the layout's channel mask (5.1, 7.1);
FLAC goes through soundfile.  Every file is written atomically, with a
sidecar JSON (``OUT.wav.json``) recording how it was made.

Devices: sounddevice (PortAudio) is imported only inside the device
functions, so ``import auralize`` never touches a sound device.
:func:`list_devices` lists output devices and their channel counts;
:func:`choose_output_device` resolves ``--device N|NAME`` against a layout's
channel count and raises :class:`~auralize.errors.DeviceError` with what to
do instead (``--downmix``, another device, or writing a file).
"""

from __future__ import annotations

import contextlib
import json
import math
import struct
import threading
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, cast, get_args

import numpy as np
from numpy.typing import NDArray

from auralize.errors import DeviceError, FormatError, OutputError, ParameterError
from auralize.runtime.files import write_pair

if TYPE_CHECKING:
    from auralize.spatial.layouts import Layout

#: normalisation of written audio (``--normalize``): peak to full scale, or pascals
Normalize = Literal["peak", "none"]
NORMALIZE_MODES: tuple[str, ...] = get_args(Normalize)
#: sample formats of WAV output (``--format``)
SampleFormat = Literal["float32", "pcm16", "pcm24"]
WAV_FORMATS: tuple[str, ...] = get_args(SampleFormat)
PEAK_LEVEL = 0.99  # full scale after peak normalisation

_KSDATAFORMAT_FLOAT = bytes.fromhex("0300000000001000800000aa00389b71")
_KSDATAFORMAT_PCM = bytes.fromhex("0100000000001000800000aa00389b71")


#: the command line being run, as the user would retype it (set by :func:`running_command`)
_COMMAND: list[str | None] = [None]


def command_line() -> str | None:
    """The ``auralize`` command line being run (``auralize ARGS``, shell-quoted), or None.

    Every sidecar records it under ``"command"``.

    Returns
    -------
    str or None
        None outside :func:`running_command` (audio written from Python).

    Examples
    --------
    >>> command_line() is None
    True
    >>> with running_command(["info", "a.h5"]):
    ...     command_line()
    'auralize info a.h5'
    """
    return _COMMAND[0]


@contextlib.contextmanager
def running_command(argv: Sequence[str]) -> Iterator[str]:
    """Record ``auralize ARGV`` (shell-quoted) as :func:`command_line` while the block runs.

    Parameters
    ----------
    argv : sequence of str
        The arguments :func:`auralize.cli.main` parsed (without the program name).

    Yields
    ------
    str
        The recorded command line.

    Examples
    --------
    >>> with running_command(["render", "my data.h5", "-o", "a.wav"]) as cmd:
    ...     cmd == command_line()
    True
    >>> cmd
    "auralize render 'my data.h5' -o a.wav"
    >>> command_line() is None
    True
    """
    import shlex

    old = _COMMAND[0]
    _COMMAND[0] = "auralize " + shlex.join(str(a) for a in argv)
    try:
        yield _COMMAND[0]
    finally:
        _COMMAND[0] = old


def normalize_audio(
    audio: NDArray[np.floating], mode: Normalize = "peak", *, limit_pa: float | None = None
) -> tuple[NDArray[np.float64], float]:
    """Apply the optional pressure limiter, then the normalisation.

    Parameters
    ----------
    audio : array_like, shape (n_channels, n_samples)
        Pressure in Pa.
    mode : {"peak", "none"}
        ``"peak"`` scales the loudest sample to :data:`PEAK_LEVEL` (0.99) full
        scale; ``"none"`` keeps pascals (a float file holds them exactly).
    limit_pa : float, optional
        Maximum pressure in Pa: samples beyond ±limit_pa are truncated, as a
        microphone's maximum sound pressure does (paper 000 §7, explosions).

    Returns
    -------
    audio : ndarray, shape (n_channels, n_samples)
        The output.
    gain : float
        The gain applied after limiting (output units per Pa; 1 for ``"none"``).

    Raises
    ------
    ParameterError
        An unknown mode, audio that is not 2-D or holds NaN/Inf, or a limit
        that is not a positive pressure.

    Examples
    --------
    >>> out, gain = normalize_audio(np.array([[0.5, -2.0]]), limit_pa=1.0)
    >>> out.tolist(), gain
    ([[0.495, -0.99]], 0.99)
    """
    if mode not in NORMALIZE_MODES:
        raise ParameterError(f"normalize must be one of {NORMALIZE_MODES}, got {mode!r}")
    a = np.asarray(audio, dtype=np.float64)
    if a.ndim != 2:
        raise ParameterError(f"audio must be (n_channels, n_samples), got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ParameterError("audio contains NaN or Inf; refusing to write it")
    if limit_pa is not None:
        if not limit_pa > 0:
            raise ParameterError(f"limit must be a positive pressure in Pa, got {limit_pa!r}")
        a = np.clip(a, -limit_pa, limit_pa)
    gain = 1.0
    if mode == "peak":
        peak = float(np.max(np.abs(a))) if a.size else 0.0
        gain = PEAK_LEVEL / peak if peak > 0 else 1.0
        a = a * gain
    return a, gain


def wav_bytes(
    audio: NDArray[np.floating],
    rate: int,
    *,
    channel_mask: int | None = None,
    subtype: SampleFormat = "float32",
) -> bytes:
    """Encode audio as the bytes of a WAV file.

    The header is WAVE_FORMAT_EXTENSIBLE when there are more than 2 channels or
    a channel mask is given; float files carry a ``fact`` chunk.

    Parameters
    ----------
    audio : array_like, shape (n_channels, n_samples)
        Samples (full scale 1 for the PCM formats).
    rate : int
        Sample rate, Hz.
    channel_mask : int, optional
        WAVE ``dwChannelMask`` (speaker positions of the channels).
    subtype : {"float32", "pcm16", "pcm24"}
        Sample format.

    Returns
    -------
    bytes

    Raises
    ------
    ParameterError
        An unknown format, or PCM samples beyond [-1, 1].

    Examples
    --------
    >>> data = wav_bytes(np.zeros((2, 100)), 48000, subtype="pcm16")
    >>> data[:4], data[8:12], len(data)   # 44-byte header + 2 ch × 100 × 2 bytes
    (b'RIFF', b'WAVE', 444)
    """
    a = np.asarray(audio, dtype=np.float64)
    n_ch, n = a.shape
    if subtype == "float32":
        data = np.ascontiguousarray(a.T, dtype="<f4").tobytes()
        bits, fmt_guid, fmt_tag = 32, _KSDATAFORMAT_FLOAT, 3
    elif subtype in ("pcm16", "pcm24"):
        if np.max(np.abs(a), initial=0) > 1.0:
            raise ParameterError(
                f"{subtype} output needs samples in [-1, 1]; use --normalize "
                "peak, or --format float32 to keep pascals"
            )
        bits = 16 if subtype == "pcm16" else 24
        ints = np.round(a.T * (2 ** (bits - 1) - 1))
        if bits == 16:
            data = np.ascontiguousarray(ints, dtype="<i2").tobytes()
        else:  # the three low bytes of each little-endian int32
            data = (
                np.ascontiguousarray(ints, dtype="<i4")
                .view(np.uint8)
                .reshape(-1, 4)[:, :3]
                .tobytes()
            )
        fmt_guid, fmt_tag = _KSDATAFORMAT_PCM, 1
    else:
        raise ParameterError(f"format must be one of {WAV_FORMATS}, got {subtype!r}")
    block_align = n_ch * bits // 8
    extensible = n_ch > 2 or channel_mask is not None
    if extensible:
        mask = channel_mask if channel_mask is not None else 0
        fmt = struct.pack(
            "<HHIIHHHHI16s",
            0xFFFE,
            n_ch,
            rate,
            rate * block_align,
            block_align,
            bits,
            22,
            bits,
            mask,
            fmt_guid,
        )
    else:
        fmt = struct.pack("<HHIIHH", fmt_tag, n_ch, rate, rate * block_align, block_align, bits)
        if fmt_tag == 3:
            fmt += struct.pack("<H", 0)
    chunks = b"fmt " + struct.pack("<I", len(fmt)) + fmt
    if fmt_tag == 3:  # every non-PCM WAV (extensible ones too) carries its sample frame count
        chunks += b"fact" + struct.pack("<II", 4, n)
    chunks += b"data" + struct.pack("<I", len(data)) + data
    return b"RIFF" + struct.pack("<I", 4 + len(chunks)) + b"WAVE" + chunks


def read_wav(path: str | Path) -> tuple[NDArray[np.float64], int, int | None]:
    """Read a WAV written by :func:`wav_bytes` (float32, pcm16 or pcm24, plain or extensible).

    Parameters
    ----------
    path : str or Path
        The WAV file.

    Returns
    -------
    audio : ndarray, shape (n_channels, n_samples)
        Samples as float64 (PCM scaled to full scale 1).
    rate : int
        Sample rate, Hz.
    channel_mask : int or None
        The extensible header's channel mask, None for a plain header.

    Raises
    ------
    FormatError
        Not RIFF/WAVE, no fmt or data chunk, or an unsupported encoding.

    Examples
    --------
    >>> _ = Path("five.wav").write_bytes(wav_bytes(np.ones((6, 3)), 44100, channel_mask=0x3F))
    >>> audio, rate, mask = read_wav("five.wav")
    >>> audio.shape, rate, hex(mask)
    ((6, 3), 44100, '0x3f')
    """
    p = Path(path)
    raw = p.read_bytes()
    if len(raw) < 12 or raw[:4] != b"RIFF" or raw[8:12] != b"WAVE":
        raise FormatError(f"{p}: not a RIFF/WAVE file")
    pos, fmt, data, mask = 12, None, None, None
    while pos + 8 <= len(raw):
        cid, size = raw[pos : pos + 4], struct.unpack("<I", raw[pos + 4 : pos + 8])[0]
        body = raw[pos + 8 : pos + 8 + size]
        if cid == b"fmt ":
            fmt = body
        elif cid == b"data":
            data = body
        pos += 8 + size + (size & 1)
    if fmt is None or data is None:
        raise FormatError(f"{p}: WAV file without fmt or data chunk")
    tag, n_ch, rate, _, _, bits = struct.unpack("<HHIIHH", fmt[:16])
    if tag == 0xFFFE:
        mask = struct.unpack("<I", fmt[20:24])[0]
        tag = struct.unpack("<H", fmt[24:26])[0]
    if tag == 3 and bits == 32:
        a = np.frombuffer(data, dtype="<f4").astype(np.float64)
    elif tag == 1 and bits == 16:
        a = np.frombuffer(data, dtype="<i2").astype(np.float64) / 32767.0
    elif tag == 1 and bits == 24:
        b = np.frombuffer(data, dtype=np.uint8).reshape(-1, 3).astype(np.int32)
        ints = b[:, 0] | (b[:, 1] << 8) | (b[:, 2] << 16)
        a = (ints - ((ints & 0x800000) << 1)).astype(np.float64) / 8388607.0
    else:
        raise FormatError(f"{p}: unsupported WAV encoding (format tag {tag}, {bits} bits)")
    return a.reshape(-1, n_ch).T.copy(), int(rate), mask


def _flac_mask_note(lay: Layout | None, sidecar: dict[str, Any] | None, n_ch: int) -> str | None:
    """:func:`auralize.spatial.layouts.flac_mask_warning` of the audio's layout: ``lay``, or
    the built-in layout named in the sidecar's ``layout``; a custom layout
    there is judged by its channel mask."""
    from auralize.errors import AuralizeError
    from auralize.spatial.layouts import flac_mask_warning, get_layout

    if lay is None:
        desc = (sidecar or {}).get("layout")
        if not isinstance(desc, dict) or "name" not in desc:
            return None
        try:
            lay = get_layout(str(desc["name"]))
        except (AuralizeError, OSError):
            lay = None
        if lay is None or lay.n_channels != n_ch:
            if desc.get("channel_mask") is None or n_ch > 8:
                return (
                    f"layout {desc['name']!r} has no standard channel mask: FLAC cannot record "
                    f"its channel positions, so players may route its {n_ch} channels as the "
                    f"standard {n_ch}-channel layout; write WAV (with the sidecar) to keep "
                    f"them"
                )
            return None
    return flac_mask_warning(lay)


def write_audio(
    path: str | Path,
    audio: NDArray[np.floating],
    rate: int,
    *,
    channel_mask: int | None = None,
    normalize: str = "peak",
    limit_pa: float | None = None,
    sidecar: dict[str, Any] | None = None,
    subtype: str | None = None,
    layout: Layout | str | None = None,
    units: str = "Pa",
) -> float:
    """Write audio to ``path`` (``.wav`` or ``.flac``) and ``path.json``, both or neither.

    The samples are checked as they will be stored: float32 overflow and a
    signal that would be stored as all zeros raise :class:`ParameterError`;
    audio that is silent (all 0) is written with ``"silent": true`` in the
    sidecar and a :class:`SilentAudioWarning`.  The sidecar records the audio
    file's SHA-256; the two are written as a pair
    (:func:`auralize.runtime.files.write_pair`).

    Parameters
    ----------
    path : str or Path
        ``.wav`` (extensible header with ``channel_mask`` when > 2 channels)
        or ``.flac`` (needs samples in [-1, 1], at most 8 channels; a layout
        without a standard channel mask, from ``layout`` or the sidecar's
        ``layout``, warns that players may route its channels as the standard
        layout: :func:`auralize.spatial.layouts.flac_mask_warning`).
    audio : array_like, shape (n_channels, n_samples)
        Pressure in Pa.
    rate : int
        Sample rate in Hz.
    channel_mask : int, optional
        WAVE ``dwChannelMask``; default the layout's.
    normalize : {"peak", "none"}
        See :func:`normalize_audio`.  With ``"peak"`` a peak below
        :data:`NOTHING_PA` is written as silence.
    limit_pa : float, optional
        Pressure limit in Pa (:func:`normalize_audio`).
    sidecar : dict, optional
        Extra entries for the sidecar JSON (``silent_why``: the reason given
        when the audio is silent).
    subtype : {"float32", "pcm16", "pcm24"}, optional
        Sample format (``--format``).  Default: float32 for WAV (with a
        ``fact`` chunk), pcm24 for FLAC.  With ``normalize="none"`` a float
        WAV holds pascals, so samples beyond ±1 are intended, not clipping;
        the PCM formats need samples in [-1, 1].
    layout : Layout or name, optional
        The audio's speaker layout: its channel count is checked, its channel
        mask used (unless ``channel_mask`` is given), per-speaker distances and
        gains are applied (:class:`~auralize.spatial.SpeakerAlignment`) and it is
        recorded in the sidecar.
    units : str
        What the samples hold before normalisation (the sidecar's ``units``:
        ``"Pa"`` at the listener, or an emitted signal's ``"Pa at 1 m"``).

    Returns
    -------
    float
        The normalisation gain (output units per pascal).

    Raises
    ------
    ParameterError
        A bad suffix, format, normalisation, limit or shape; samples that
        would overflow or be stored as all zeros; FLAC with float samples,
        samples beyond [-1, 1] or more than 8 channels.
    OutputError
        The sidecar's name is taken by a file auralize did not write, or the
        files cannot be written.

    Examples
    --------
    >>> pressure = np.array([[0.0, 2.0, -1.0, 0.5]])   # Pa
    >>> gain = write_audio("tone.wav", pressure, 48000)
    >>> audio, rate, _ = read_wav("tone.wav")
    >>> np.round(audio, 4).tolist(), rate, gain
    ([[0.0, 0.99, -0.495, 0.2475]], 48000, 0.495)
    >>> import json
    >>> json.loads(Path("tone.wav.json").read_text())["units"]
    'full scale = 2.0202 Pa'
    """
    p = Path(path)
    a = np.asarray(audio, dtype=np.float64)
    if layout is not None:
        from auralize.spatial.layouts import align_speakers, get_layout

        lay = get_layout(layout)
        if a.ndim != 2 or a.shape[0] != lay.n_channels:
            raise ParameterError(
                f"layout {lay.name!r} has {lay.n_channels} channels, audio has shape {a.shape}"
            )
        if lay.needs_alignment:
            a = align_speakers(a, lay, rate)
        if channel_mask is None:
            channel_mask = lay.channel_mask
        sidecar = {"layout": lay.describe(), **(sidecar or {})}
    suffix = p.suffix.lower()
    if subtype is not None and subtype not in WAV_FORMATS:
        raise ParameterError(f"format must be one of {WAV_FORMATS}, got {subtype!r}")
    if subtype is None:
        subtype = "pcm24" if suffix == ".flac" else "float32"
    sample_format = cast(SampleFormat, subtype)  # one of WAV_FORMATS (checked above)
    if suffix not in (".wav", ".flac"):
        raise ParameterError(f"{p}: audio output must end in .wav or .flac")
    nothing = ""
    peak_in = float(np.max(np.abs(a), initial=0.0)) if a.size and np.all(np.isfinite(a)) else 0.0
    if normalize == "peak" and 0.0 < peak_in < NOTHING_PA:
        # no pressure this small is sound (10⁹ below the thermal noise of air): it is
        # round-off, or a field that does nothing; full scale would make it sound
        nothing = (
            f"the pressure peaks at {peak_in:.3g} Pa, below {NOTHING_PA:g} Pa: round-off "
            f"or nothing, written as silence rather than amplified to full scale"
        )
        a = np.zeros_like(a)
    out, gain = normalize_audio(a, cast(Normalize, normalize), limit_pa=limit_pa)  # checked there
    if suffix == ".flac" and subtype == "float32":
        raise ParameterError("FLAC holds integer samples; use --format pcm16|pcm24 or a WAV file")
    if suffix == ".flac" and out.shape[0] > 8:
        raise ParameterError(
            f"{p}: FLAC holds at most 8 channels, the audio has {out.shape[0]} "
            f"(e.g. ambix2/ambix3): write a WAV file"
        )
    silent = _check_stored(out, gain, p, subtype)
    if silent:
        # the render's own reason when it has one (a field that does nothing that sounds)
        why = (
            nothing
            or str((sidecar or {}).get("silent_why") or "")
            or (
                "no sound reached the listener within the duration (no sources, thresholds too "
                "high, or the listener too far away)"
            )
        )
        warnings.warn(
            f"{p}: the audio is silent (every sample is 0): {why}; the file is written and "
            f"marked silent in its sidecar",
            SilentAudioWarning,
            stacklevel=2,
        )
    if suffix == ".flac" and normalize == "none" and np.max(np.abs(out), initial=0) > 1:
        raise ParameterError("FLAC holds samples in [-1, 1]; use --normalize peak or a WAV file")
    if suffix == ".flac":
        note = _flac_mask_note(lay if layout is not None else None, sidecar, out.shape[0])
        if note:
            warnings.warn(f"{p}: {note}", UserWarning, stacklevel=2)
    check_sidecar_target(Path(str(p) + ".json"))
    meta = {
        "auralize_format": SIDECAR_FORMAT,
        "file": p.name,
        "rate": int(rate),
        "channels": int(out.shape[0]),
        "samples": int(out.shape[1]),
        "normalize": normalize,
        "gain": gain,
        "units": units if normalize == "none" else f"full scale = {1 / gain:.6g} {units}",
        "format": subtype,
        **(
            {
                "note": "float samples in pascals: values beyond ±1 are intended, not clipping; "
                "scale them before playing"
            }
            if normalize == "none" and subtype == "float32"
            else {}
        ),
        "limit_pa": limit_pa,
        "silent": silent,
        **({"silent_why": nothing} if nothing else {}),
        "command": command_line(),
        **(sidecar or {}),
    }

    def write_main(tmp: Path) -> None:
        if suffix == ".wav":
            tmp.write_bytes(
                wav_bytes(out, int(rate), channel_mask=channel_mask, subtype=sample_format)
            )
        else:
            import soundfile as sf

            sf.write(
                str(tmp),
                out.T,
                int(rate),
                format="FLAC",
                subtype=subtype.upper().replace("PCM", "PCM_"),
            )

    def sidecar_bytes(sha256: str) -> bytes:
        return json.dumps({**meta, "sha256": sha256}, indent=2, default=_json_default).encode()

    from auralize.runtime.resources import require_disk

    bytes_per_sample = 4 if suffix == ".wav" and subtype == "float32" else 3
    require_disk(
        p, out.size * bytes_per_sample + 65536, f"{out.shape[1]} samples x {out.shape[0]} channels"
    )
    write_pair(
        p,
        write_main,
        Path(str(p) + ".json"),
        sidecar_bytes,
        suffix=".part.flac" if suffix == ".flac" else ".part",
    )
    return gain


#: the marker of an audio file's sidecar (``OUT.wav.json``)
SIDECAR_FORMAT = "audio-sidecar"


def check_sidecar_target(path: str | Path) -> None:
    """Refuse to replace ``path`` (an audio file's sidecar to be) unless auralize wrote it.

    A sidecar of ours carries ``"auralize_format": "audio-sidecar"`` (or,
    written before that marker, the keys ``file``, ``rate`` and ``command``).

    Parameters
    ----------
    path : str or Path
        The sidecar to be written (``OUT.wav.json``).

    Raises
    ------
    OutputError
        ``path`` exists and is not one of auralize's sidecars.

    Examples
    --------
    >>> check_sidecar_target("new.wav.json")   # does not exist: fine
    >>> _ = Path("notes.wav.json").write_text('{"mine": 1}')
    >>> check_sidecar_target("notes.wav.json")
    Traceback (most recent call last):
    auralize.errors.OutputError: notes.wav.json: exists and is not an auralize sidecar; ...
    """
    p = Path(path)
    if not p.exists():
        return
    ours = False
    try:
        if p.is_file() and p.stat().st_size < (16 << 20):
            d = json.loads(p.read_text())
            ours = isinstance(d, dict) and (
                d.get("auralize_format") == SIDECAR_FORMAT or {"file", "rate", "command"} <= set(d)
            )
    except (OSError, ValueError, UnicodeDecodeError):
        ours = False
    if not ours:
        raise OutputError(
            f"{p}: exists and is not an auralize sidecar; writing the audio would replace it "
            f"(the sidecar of OUT.wav is OUT.wav.json): move it, or name another output"
        )


#: a peak pressure below this (Pa) is not normalised to full scale but written as
#: silence: −334 dB re 20 µPa, 10⁹ below the thermal noise of air (about 10⁻⁶ Pa)
NOTHING_PA = 1e-15


class SilentAudioWarning(UserWarning):
    """An audio file was written whose samples are all 0 (nothing was heard).

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = write_audio("quiet.wav", np.zeros((1, 64)), 8000)
    >>> [w.category.__name__ for w in caught]
    ['SilentAudioWarning']
    """


#: largest magnitude a float32 sample holds
_F32_MAX = float(np.finfo(np.float32).max)


def _check_stored(out: NDArray[np.float64], gain: float, path: Path, encoding: str) -> bool:
    """Check the samples as they will be stored; return True if the audio is silent.

    Raises :class:`ParameterError` when float32 overflows (pressures beyond
    3.4e38 Pa with ``--normalize none``) or when a non-silent signal would be
    stored as all zeros (values below the encoding's smallest step).
    """
    if not np.isfinite(gain):
        raise ParameterError(
            f"{path}: the loudest sample is too small to normalise (gain {gain!r}); the signal "
            f"underflows — check the source strengths, or write --normalize none"
        )
    peak = float(np.max(np.abs(out))) if out.size else 0.0
    if out.shape[-1] == 0:
        raise ParameterError(f"{path}: the audio has no samples; give a longer duration or rate")
    if encoding == "float32":
        with np.errstate(over="ignore"):
            stored_peak = float(np.max(np.abs(out.astype(np.float32))))
        if not np.isfinite(stored_peak) or peak > _F32_MAX:
            raise ParameterError(
                f"{path}: peak pressure {peak:.3g} Pa overflows a float32 WAV (max "
                f"{_F32_MAX:.3g}); use --normalize peak or --limit PA"
            )
    else:
        step = 1 / 32767 if encoding == "pcm16" else 1 / 8388607
        stored_peak = float(np.round(peak / step)) * step
    if peak > 0 and stored_peak == 0:
        raise ParameterError(
            f"{path}: peak pressure {peak:.3g} is below the smallest {encoding} sample, so the "
            f"file would be all zeros; use --normalize peak"
        )
    return peak == 0


def _json_default(o: object) -> object:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    return str(o)


# ------------------------------------------------------------------ devices
def import_sounddevice() -> Any:
    """Import sounddevice (PortAudio) on demand.

    Returns
    -------
    module
        The ``sounddevice`` module.

    Raises
    ------
    DeviceError
        PortAudio cannot be loaded (with the package to install).

    Examples
    --------
    >>> import_sounddevice().__name__
    'sounddevice'
    """
    try:
        import sounddevice
    except OSError as exc:  # libportaudio missing
        raise DeviceError(
            f"cannot load PortAudio for live playback ({exc}); install libportaudio2 "
            f"(apt-get install libportaudio2) or write a file with 'auralize render -o out.wav'"
        ) from None
    return sounddevice


def refresh_devices() -> None:
    """Re-scan sound devices (PortAudio enumerates them once, at initialisation).

    Call after plugging in a device or changing the ALSA configuration.

    Raises
    ------
    DeviceError
        PortAudio cannot be loaded.

    Examples
    --------
    >>> refresh_devices()
    >>> isinstance(list_devices(), list)
    True
    """
    sd = import_sounddevice()
    sd._terminate()
    sd._initialize()


def list_devices(*, outputs_only: bool = True) -> list[dict[str, Any]]:
    """Sound devices as dicts (output devices only by default).

    Parameters
    ----------
    outputs_only : bool
        Leave out devices without output channels.

    Returns
    -------
    list of dict
        One dict per device with ``index``, ``name``, ``hostapi``,
        ``max_output_channels``, ``max_input_channels``,
        ``default_samplerate`` (Hz) and ``default`` (the default output).

    Raises
    ------
    DeviceError
        PortAudio cannot be loaded or queried.

    Examples
    --------
    >>> devices = list_devices()  # what PortAudio sees: may be none
    >>> all(d["max_output_channels"] > 0 for d in devices)
    True
    """
    sd = import_sounddevice()
    try:
        default_out = sd.default.device[1]
        devs = sd.query_devices()
        apis = sd.query_hostapis()
    except sd.PortAudioError as exc:
        raise DeviceError(f"cannot query sound devices: {exc}") from None
    out = []
    for i, d in enumerate(devs):
        if outputs_only and d["max_output_channels"] < 1:
            continue
        out.append(
            {
                "index": i,
                "name": d["name"],
                "hostapi": apis[d["hostapi"]]["name"],
                "max_output_channels": int(d["max_output_channels"]),
                "max_input_channels": int(d["max_input_channels"]),
                "default_samplerate": float(d["default_samplerate"]),
                "default": i == default_out,
            }
        )
    return out


def _no_device_error() -> DeviceError:
    return DeviceError(
        "no audio output device found (PortAudio sees none: no sound card, or no access to "
        "it); write a file instead, e.g. 'auralize render VOLUME --path PATH.csv --layout ring8 "
        "-o out.wav', and play it elsewhere"
    )


def choose_output_device(
    device: int | str | None, channels: int, *, downmix: bool = False
) -> dict[str, Any]:
    """Resolve ``device`` (index, name substring, or None for the default output).

    Parameters
    ----------
    device : int, str or None
        A device index from :func:`list_devices`, a (case-insensitive, unique)
        part of its name, or None for the default output device.
    channels : int
        Channels the layout needs.
    downmix : bool
        Accept a device with fewer channels (the caller folds the layout down).

    Returns
    -------
    dict
        The device's entry from :func:`list_devices`.

    Raises
    ------
    DeviceError
        No output device at all; index out of range; no or several matching
        names; an input-only device; too few channels without ``downmix``.

    Examples
    --------
    >>> choose_output_device("no such device", 2)
    Traceback (most recent call last):
    auralize.errors.DeviceError: ...
    """
    all_devs = list_devices(outputs_only=False)
    outs = [d for d in all_devs if d["max_output_channels"] > 0]
    if not outs:
        raise _no_device_error()
    names = ", ".join(f"{d['index']}: {d['name']} ({d['max_output_channels']} ch)" for d in outs)
    if device is None or (isinstance(device, str) and device.strip().lower() in ("", "default")):
        dflt = [d for d in outs if d["default"]]
        dev = dflt[0] if dflt else outs[0]
    elif isinstance(device, int) or (isinstance(device, str) and device.strip().isdigit()):
        idx = int(device)
        if not 0 <= idx < len(all_devs):
            raise DeviceError(
                f"device index {idx} is out of range: there are {len(all_devs)} devices "
                f"(0..{len(all_devs) - 1}); output devices: {names}"
            )
        dev = all_devs[idx]
        if dev["max_output_channels"] < 1:
            raise DeviceError(
                f"device {idx} ({dev['name']}) has no output channels; output devices: {names}"
            )
    else:
        key = str(device).strip().lower()
        hits = [d for d in outs if key == d["name"].lower()] or [
            d for d in outs if key in d["name"].lower()
        ]
        if not hits:
            raise DeviceError(f"no output device matches {device!r}; output devices: {names}")
        if len(hits) > 1:
            raise DeviceError(
                f"{device!r} matches several devices "
                f"({', '.join(repr(d['name']) for d in hits)}); give its index"
            )
        dev = hits[0]
    if dev["max_output_channels"] < channels and not downmix:
        from auralize.spatial.layouts import downmix_target

        target = downmix_target("ring8", dev["max_output_channels"]).name
        raise DeviceError(
            f"device {dev['index']} ({dev['name']}) has {dev['max_output_channels']} output "
            f"channels but the layout needs {channels}; add --downmix to fold it to {target}, "
            f"choose another device (see 'auralize devices'), or write a file with -o"
        )
    return dev


def downmix(
    audio: NDArray[np.floating], src: Layout | str, dst: Layout | str
) -> NDArray[np.float64]:
    """Fold audio of one layout into another.

    Parameters
    ----------
    audio : array_like, shape (src.n_channels, n)
        Audio in ``src``'s channel order.
    src, dst : Layout or str
        Layouts (names or JSON files, :func:`auralize.spatial.layouts.get_layout`).

    Returns
    -------
    ndarray, shape (dst.n_channels, n)
        ``downmix_matrix(src, dst) @ audio``
        (:func:`auralize.spatial.layouts.downmix_matrix`).

    Raises
    ------
    ParameterError
        ``audio`` does not have ``src``'s channels; a target that needs filters
        (binaural).

    Examples
    --------
    >>> front = np.zeros((8, 3)); front[0] = 1.0      # ring8 channel 0: straight ahead
    >>> np.round(downmix(front, "ring8", "stereo"), 4).tolist()
    [[0.7071, 0.7071, 0.7071], [0.7071, 0.7071, 0.7071]]
    """
    from auralize.spatial.layouts import get_layout

    return get_layout(src).downmix(audio, dst)


# ------------------------------------------------------------ safe playback
#: the loudest sample a device is ever given (full scale is 1.0)
CEILING = 0.99
#: auto gain of live listening: the first sound's peak is placed this far below full scale
LIVE_HEADROOM_DB = 6.0


class Limiter:
    """Gain and a peak limiter between pascals and a device: nothing beyond full scale.

    Each block is multiplied by ``gain`` (full scale per pascal, times
    ``10**(gain_db/20)``), then by a limiter envelope: when a block's peak would
    exceed :data:`CEILING` the envelope drops at once to bring that peak to the
    ceiling (instant attack, at the block's start), and recovers towards 1 with
    time constant ``release_s``.  Within a block the envelope never exceeds the
    value that keeps the block's peak at the ceiling, so ``|out| <= CEILING``
    always; a final clip guards against rounding.  The level meter
    (:attr:`peak_dbfs`, :attr:`rms_dbfs`, :attr:`reduction_db`) describes the
    last block sent.

    Parameters
    ----------
    gain : float or None
        Full scale per pascal; None (auto) sets it from the first block that is
        not silent, :data:`LIVE_HEADROOM_DB` below full scale.
    gain_db : float
        Extra gain in dB on top (the panel's gain control).
    rate : int
        Sample rate in Hz (for the release time).
    release_s : float
        Seconds for the limiter's gain reduction to recover by a factor e.

    Examples
    --------
    >>> lim = Limiter(gain=1.0, rate=1000)
    >>> out = lim.process(np.array([[0.5, 4.0, -8.0, 0.1]]))
    >>> float(np.max(np.abs(out))) < 1.0, round(lim.reduction_db, 1)
    (True, -18.1)
    """

    def __init__(
        self,
        gain: float | None = None,
        *,
        gain_db: float = 0.0,
        rate: int = 44100,
        release_s: float = 0.5,
    ) -> None:
        if gain is not None and not (np.isfinite(gain) and gain > 0):
            raise ParameterError(
                f"gain must be a positive number (full scale per Pa), got {gain!r}"
            )
        self.gain = None if gain is None else float(gain)
        self.gain_db = check_gain_db(gain_db)
        self.rate = int(rate)
        self.release_s = float(release_s)
        self.envelope = 1.0
        self.peak_dbfs = -math.inf
        self.rms_dbfs = -math.inf
        self.reduction_db = 0.0
        self.limited_blocks = 0

    def process(self, block: NDArray[np.floating]) -> NDArray[np.float32]:
        """Gain and limit one block: pascals to float32 samples within ±:data:`CEILING`.

        Parameters
        ----------
        block : array_like, shape (n_channels, n)
            Pressure in Pa (NaN/Inf are taken as 0).

        Returns
        -------
        ndarray of float32, shape (n_channels, n)

        Raises
        ------
        ParameterError
            A block that is not 2-D.

        Examples
        --------
        >>> lim = Limiter(gain=None)   # auto: the first sound 6 dB below full scale
        >>> out = lim.process(np.array([[0.0, 2.0, -1.0]]))
        >>> np.round(out.astype(float), 4).tolist(), round(lim.peak_dbfs, 2)
        ([[0.0, 0.5012, -0.2506]], -6.0)
        """
        x = np.asarray(block, dtype=np.float64)
        if x.ndim != 2:
            raise ParameterError(f"block must be (n_channels, n), got shape {x.shape}")
        x = np.where(np.isfinite(x), x, 0.0)
        peak_in = float(np.max(np.abs(x), initial=0.0))
        if self.gain is None:
            if peak_in == 0:
                self._meter(x.astype(np.float32), 1.0)
                return x.astype(np.float32)
            self.gain = 10 ** (-LIVE_HEADROOM_DB / 20) / peak_in
        y = x * (self.gain * 10 ** (self.gain_db / 20))
        n = y.shape[1]
        peak = float(np.max(np.abs(y), initial=0.0))
        cap = CEILING / peak if peak > CEILING else 1.0
        start = min(self.envelope, cap)
        if n:
            rec = 1.0 - np.exp(-n / (self.rate * self.release_s))
            end = start + (1.0 - start) * rec
            env = np.minimum(np.linspace(start, end, n), cap)
            y = np.clip(y * env, -CEILING, CEILING)
            self.envelope = float(env[-1])
            if cap < 1.0:
                self.limited_blocks += 1
            out = y.astype(np.float32)
            self._meter(out, float(env.min()))
            return out
        return y.astype(np.float32)

    def _meter(self, out: NDArray[np.float32], env_min: float) -> None:
        p = float(np.max(np.abs(out), initial=0.0))
        r = float(np.sqrt(np.mean(np.square(out, dtype=np.float64)))) if out.size else 0.0
        self.peak_dbfs = float(20 * np.log10(p)) if p > 0 else -math.inf
        self.rms_dbfs = float(20 * np.log10(r)) if r > 0 else -math.inf
        self.reduction_db = float(20 * np.log10(env_min)) if env_min > 0 else -math.inf


def check_gain_db(gain_db: float) -> float:
    """A gain control value in dB, checked (finite, within ±60 dB).

    Parameters
    ----------
    gain_db : float
        Gain in dB (anything ``float()`` accepts).

    Returns
    -------
    float

    Raises
    ------
    ParameterError
        Not a number, or outside -60..60 dB.

    Examples
    --------
    >>> check_gain_db("-6")
    -6.0
    >>> check_gain_db(80)
    Traceback (most recent call last):
    auralize.errors.ParameterError: gain must be within -60..60 dB, got 80
    """
    try:
        g = float(gain_db)
    except (TypeError, ValueError):
        raise ParameterError(f"gain must be a number of dB, got {gain_db!r}") from None
    if not (np.isfinite(g) and -60 <= g <= 60):
        raise ParameterError(f"gain must be within -60..60 dB, got {gain_db!r}")
    return g


class Playback:
    """A sound being played by :func:`play` (a worker thread feeds the device).

    :func:`play` builds it on a device's stream and starts its thread.

    Parameters
    ----------
    audio : ndarray, shape (n_channels, n_samples)
        Pressure in Pa.
    rate : int
        Sample rate, Hz.
    stream : object
        Where the blocks go: ``write(block)`` takes a float32
        ``(n_channels, n)`` block, ``close(drain=...)`` ends the stream (a
        :class:`auralize.audio.live.LiveStream` on a device).
    limiter : Limiter
        Gain and limiter applied to each block.
    block : int
        Frames per block.

    Attributes
    ----------
    limiter : Limiter
        Its level meter describes the block last sent.
    frames_sent : int
        Sample frames given to the device so far.
    error : BaseException or None
        What stopped the playback early, if anything.

    Examples
    --------
    >>> class Sink:   # anything with write(block) and close(drain=...)
    ...     def __init__(self): self.blocks = []
    ...     def write(self, block): self.blocks.append(block)
    ...     def close(self, drain): self.drained = drain
    >>> pb = Playback(np.ones((2, 10)), 10, stream=Sink(), limiter=Limiter(0.5), block=4)
    >>> pb.duration_s, pb.running, pb.frames_sent
    (1.0, False, 0)
    """

    def __init__(
        self, audio: NDArray[np.float64], rate: int, *, stream: Any, limiter: Limiter, block: int
    ) -> None:
        self.audio, self.rate, self.stream, self.limiter = audio, int(rate), stream, limiter
        self.block = int(block)
        self.frames_sent = 0
        self.error: BaseException | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="auralize-play", daemon=True)

    @property
    def duration_s(self) -> float:
        """Length of the sound, s.

        Examples
        --------
        >>> Playback(np.ones((1, 22050)), 44100, stream=None, limiter=Limiter(), block=1024).duration_s
        0.5
        """
        return self.audio.shape[1] / self.rate

    @property
    def running(self) -> bool:
        """Whether the sound is still being played.

        Examples
        --------
        >>> Playback(np.ones((1, 10)), 10, stream=None, limiter=Limiter(), block=4).running
        False
        """
        return self._thread.is_alive()

    def _run(self) -> None:
        drained = False
        try:
            for a in range(0, self.audio.shape[1], self.block):
                if self._stop.is_set():
                    break
                self.stream.write(self.limiter.process(self.audio[:, a : a + self.block]))
                self.frames_sent += min(self.block, self.audio.shape[1] - a)
            else:
                self.stream.close(drain=True)
                drained = True
        except BaseException as exc:  # kept for the caller (the viewer shows it)
            self.error = exc
        finally:
            if not drained:
                try:
                    self.stream.close(drain=False)
                except BaseException as exc:  # the device is gone: nothing more to do
                    self.error = self.error or exc
            with _PLAYING_LOCK:
                if self in _PLAYING:
                    _PLAYING.remove(self)

    def stop(self, timeout: float = 2.0) -> None:
        """Stop at the next block (within one block's time) and close the device.

        Parameters
        ----------
        timeout : float
            Seconds to wait for the worker thread to end.

        Examples
        --------
        >>> pb = Playback(np.ones((1, 10)), 10, stream=None, limiter=Limiter(), block=4)
        >>> pb.stop()   # before it starts: nothing will be played
        >>> pb.running, pb.frames_sent
        (False, 0)
        """
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout)

    def wait(self, timeout: float | None = None) -> Playback:
        """Block until the sound has played (re-raises a device error).

        Parameters
        ----------
        timeout : float, optional
            Seconds to wait at most (None: until the end).

        Returns
        -------
        Playback
            Itself.

        Raises
        ------
        BaseException
            What stopped the playback (a device error), if anything.

        Examples
        --------
        >>> class Sink:
        ...     def write(self, block): pass
        ...     def close(self, drain): pass
        >>> pb = Playback(np.ones((2, 10)), 10, stream=Sink(), limiter=Limiter(0.5), block=4)
        >>> pb._thread.start()   # as play() does
        >>> pb.wait().frames_sent, pb.running
        (10, False)
        """
        self._thread.join(timeout)
        if self.error is not None:
            raise self.error
        return self


_PLAYING: list[Playback] = []
_PLAYING_LOCK = threading.Lock()


def play(
    audio: Any,
    rate: int | None = None,
    *,
    device: int | str | None = None,
    gain: float | Literal["auto"] = "auto",
    gain_db: float = 0.0,
    blocking: bool = True,
    block: int = 2048,
) -> Playback:
    """Play audio (pascals) on a sound device through a gain control and a limiter.

    Parameters
    ----------
    audio : (n_channels, n_samples) array in Pa, or a :class:`~auralize.emitters.synthesis.Rendered`
        (its rate is used).
    rate : int
        Sample rate in Hz (required for an array).
    device : int, str or None
        See :func:`choose_output_device`; the device must have the audio's channels.
    gain : "auto" or float
        Full scale per pascal; ``"auto"`` puts the loudest sample at :data:`CEILING`.
    gain_db : float
        Extra gain in dB (the Audio panel's control); what would exceed full scale is
        limited (:class:`Limiter`), never clipped by the device.
    blocking : bool
        Wait until the sound has played; else return at once (:meth:`Playback.stop`,
        :func:`stop`).
    block : int
        Frames per block given to the device.

    Returns
    -------
    Playback
        The sound being played (finished when ``blocking``).

    Raises
    ------
    ParameterError
        A bad rate, audio shape, gain or block.
    DeviceError
        No usable output device, or too few channels.

    Examples
    --------
    ``play(rendered)`` plays a render on the default output and waits;
    ``play(audio, 44100, device="auralize_file", blocking=False)`` picks a device
    by name and returns at once.  A device that does not exist is refused
    before anything is opened:

    >>> play(np.zeros((2, 4410)), 44100, device="no such device")
    Traceback (most recent call last):
    auralize.errors.DeviceError: ...
    """
    from auralize.audio.live import open_stream

    if hasattr(audio, "audio") and hasattr(audio, "rate"):
        rate = audio.rate if rate is None else rate
        audio = audio.audio
    if rate is None or not (isinstance(rate, int | np.integer) and rate > 0):
        raise ParameterError(f"rate must be a positive integer number of Hz, got {rate!r}")
    a = np.asarray(audio, dtype=np.float64)
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] == 0:
        raise ParameterError(f"audio must be (n_channels, n_samples) with samples, got {a.shape}")
    if gain == "auto":
        peak = float(np.max(np.abs(a[np.isfinite(a)]), initial=0.0))
        g = CEILING / peak if peak > 0 else 1.0
    elif isinstance(gain, int | float) and np.isfinite(gain) and gain > 0:
        g = float(gain)
    else:
        raise ParameterError(f"gain must be 'auto' or a positive number, got {gain!r}")
    lim = Limiter(g, gain_db=gain_db, rate=int(rate))
    if not (isinstance(block, int) and block > 0):
        raise ParameterError(f"block must be a positive number of frames, got {block!r}")
    stream = open_stream(rate=int(rate), channels=a.shape[0], device=device)
    pb = Playback(a, int(rate), stream=stream, limiter=lim, block=block)
    with _PLAYING_LOCK:
        _PLAYING.append(pb)
    pb._thread.start()
    if blocking:
        pb.wait()
    return pb


def stop() -> None:
    """Stop every sound started by :func:`play`.

    Examples
    --------
    >>> stop()   # nothing playing: nothing to do
    """
    with _PLAYING_LOCK:
        playing = list(_PLAYING)
    for pb in playing:
        pb.stop()


def fit_duration(x: np.ndarray, rate: int, duration: float | None) -> np.ndarray:
    """An emitted signal cut, or padded with silence, to ``duration`` seconds.

    Parameters
    ----------
    x : ndarray, shape (n_samples,) or (n_channels, n_samples)
        The signal.
    rate : int
        Sample rate in Hz.
    duration : float or None
        Seconds (``--duration``); None returns ``x`` unchanged.

    Returns
    -------
    ndarray
        ``x`` with ``round(duration * rate)`` samples on its last axis.

    Examples
    --------
    >>> fit_duration(np.arange(1.0, 6.0), 10, 0.3).tolist()
    [1.0, 2.0, 3.0]
    >>> fit_duration(np.ones((1, 2)), 10, 0.4).tolist()
    [[1.0, 1.0, 0.0, 0.0]]
    """
    if duration is None:
        return x
    n = round(float(duration) * int(rate))
    if n <= x.shape[-1]:
        return x[..., :n]
    pad = [(0, 0)] * (x.ndim - 1) + [(0, n - x.shape[-1])]
    return np.pad(x, pad)
