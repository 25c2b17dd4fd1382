"""Sound out: the only package that touches sound files and devices.

* :mod:`auralize.audio.output` — WAV/FLAC files, normalisation, devices,
  limiter and playback (the public names below);
* :mod:`auralize.audio.live` — live playback: the blocks of a render
  (``auralize.pipeline.render(..., block=N)``) synthesized ahead of a device.

``import auralize.audio`` opens no device and imports no sounddevice.
"""

from auralize.runtime.lazy import lazy_exports

#: exported name -> sub-module, imported on first access
_EXPORTS = {
    "NORMALIZE_MODES": ".output",
    "WAV_FORMATS": ".output",
    "PEAK_LEVEL": ".output",
    "normalize_audio": ".output",
    "wav_bytes": ".output",
    "read_wav": ".output",
    "write_audio": ".output",
    "SilentAudioWarning": ".output",
    "refresh_devices": ".output",
    "list_devices": ".output",
    "choose_output_device": ".output",
    "downmix": ".output",
    "CEILING": ".output",
    "LIVE_HEADROOM_DB": ".output",
    "Limiter": ".output",
    "check_gain_db": ".output",
    "Playback": ".output",
    "play": ".output",
    "stop": ".output",
    "fit_duration": ".output",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = [
    "CEILING",
    "LIVE_HEADROOM_DB",
    "NORMALIZE_MODES",
    "PEAK_LEVEL",
    "WAV_FORMATS",
    "Limiter",
    "Playback",
    "SilentAudioWarning",
    "check_gain_db",
    "choose_output_device",
    "downmix",
    "fit_duration",
    "list_devices",
    "normalize_audio",
    "play",
    "read_wav",
    "refresh_devices",
    "stop",
    "wav_bytes",
    "write_audio",
]
