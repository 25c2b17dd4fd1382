"""Spatial audio: speaker layouts, panning, binaural and Ambisonics.

* :mod:`auralize.spatial.layouts` — layouts, 2-D/3-D VBAP panning, the
  listener frame, downmix and the output stage (the public names below);
* :mod:`auralize.spatial.ambisonics` — real spherical harmonics, AmbiX
  encoding and decoding;
* :mod:`auralize.spatial.hrtf` — HRIR sets and the binaural decoder;
* :mod:`auralize.spatial.sofa` — SOFA (AES69) HRIR files.
"""

from auralize.runtime.lazy import lazy_exports

#: exported name -> sub-module, imported on first access
_EXPORTS = {
    "C0_ALIGN": ".layouts",
    "Speaker": ".layouts",
    "Layout": ".layouts",
    "BUILTIN_LAYOUTS": ".layouts",
    "BINAURAL_ORDER": ".layouts",
    "ambix_layout": ".layouts",
    "binaural_layout": ".layouts",
    "IMMERSIVE_LAYOUTS": ".layouts",
    "is_ambisonic": ".layouts",
    "is_binaural": ".layouts",
    "get_layout": ".layouts",
    "load_layout_json": ".layouts",
    "make_layout": ".layouts",
    "vbap_gains": ".layouts",
    "Triangulation": ".layouts",
    "triangulate": ".layouts",
    "vbap3d_gains": ".layouts",
    "pan_gains": ".layouts",
    "listener_frame_azimuth": ".layouts",
    "listener_frame": ".layouts",
    "downmix_matrix": ".layouts",
    "downmix_target": ".layouts",
    "SpeakerAlignment": ".layouts",
    "align_speakers": ".layouts",
    "synthesis_layout": ".layouts",
    "OutputStage": ".layouts",
    "default_hrtf": ".layouts",
    "output_stage": ".layouts",
    "flac_mask_warning": ".layouts",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = [
    "BINAURAL_ORDER",
    "BUILTIN_LAYOUTS",
    "C0_ALIGN",
    "IMMERSIVE_LAYOUTS",
    "Layout",
    "OutputStage",
    "Speaker",
    "SpeakerAlignment",
    "Triangulation",
    "align_speakers",
    "ambix_layout",
    "binaural_layout",
    "default_hrtf",
    "downmix_matrix",
    "downmix_target",
    "flac_mask_warning",
    "get_layout",
    "is_ambisonic",
    "is_binaural",
    "listener_frame",
    "listener_frame_azimuth",
    "load_layout_json",
    "make_layout",
    "output_stage",
    "pan_gains",
    "synthesis_layout",
    "triangulate",
    "vbap3d_gains",
    "vbap_gains",
]
