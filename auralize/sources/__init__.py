"""Source detection: strengths, classification and ΔV spheres (paper 003 §3.2.3–3.2.4).

* :mod:`auralize.sources.detection` — monopole/dipole/quadrupole strengths,
  thresholds, classification and extraction (the public names below): what
  is *drawn*;
* :mod:`auralize.sources.field` — the whole field's sound (every point, no
  threshold, blocks heard through proxies): what is *heard*;
* :mod:`auralize.sources.mapping` — acoustic mappings: field values to
  density and particle velocity (paper 003 §3.2.2), the first step of both;
* :mod:`auralize.sources.sources_file` — detected sources saved and read back
  (``.h5``, ``.pvd``);
* :mod:`auralize.sources._kernels` — its fused numba stencils.

The ``field`` sound model (detected sources as a
:class:`~auralize.plugins.SoundModel`) is :mod:`auralize.field_model`, above
the pipeline it drives.

The names are imported on first use, so ``import auralize.sources`` compiles
no kernel.
"""

from auralize.runtime.lazy import lazy_exports

#: exported name -> sub-module, imported on first access
_EXPORTS = {
    "KIND_NAMES": ".detection",
    "TYPES": ".detection",
    "AUTO_NOISE_K": ".detection",
    "AUTO_COVER": ".detection",
    "AUTO_TOP": ".detection",
    "AUTO_FRACTIONS": ".detection",
    "AUTO_SAMPLE_STEPS": ".detection",
    "SAMPLE_POINTS": ".detection",
    "ROUNDOFF": ".detection",
    "WARN_FRACTION": ".detection",
    "STEADY_MODES": ".detection",
    "DELTA_V_RULES": ".detection",
    "SourceFractionWarning": ".detection",
    "ThresholdSpec": ".detection",
    "StrengthStats": ".detection",
    "auto_threshold": ".detection",
    "Thresholds": ".detection",
    "SourceFrame": ".detection",
    "SourceSeries": ".detection",
    "SourceTracks": ".detection",
    "valid_mask": ".detection",
    "field_tracks": ".field",
    "FieldTracks": ".field",
    "Heard": ".field",
    "parse_heard": ".field",
    "step_strengths": ".detection",
    "STRESS_PAIRS": ".detection",
    "steady_strength": ".detection",
    "SteadyBase": ".detection",
    "steady_anchors": ".detection",
    "compute_strengths": ".detection",
    "classify": ".detection",
    "extract": ".detection",
    "input_scale": ".detection",
    "sample_stats": ".detection",
    "sample_steps": ".detection",
    "strength_stats": ".detection",
    "peak_strengths": ".detection",
    "iter_detect": ".detection",
    "classified_fraction": ".detection",
    "warn_fraction": ".detection",
    "detect": ".detection",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = [
    "AUTO_COVER",
    "AUTO_FRACTIONS",
    "AUTO_NOISE_K",
    "AUTO_SAMPLE_STEPS",
    "AUTO_TOP",
    "DELTA_V_RULES",
    "KIND_NAMES",
    "ROUNDOFF",
    "SAMPLE_POINTS",
    "STEADY_MODES",
    "STRESS_PAIRS",
    "TYPES",
    "WARN_FRACTION",
    "FieldTracks",
    "Heard",
    "SourceFractionWarning",
    "SourceFrame",
    "SourceSeries",
    "SourceTracks",
    "SteadyBase",
    "StrengthStats",
    "ThresholdSpec",
    "Thresholds",
    "auto_threshold",
    "classified_fraction",
    "classify",
    "compute_strengths",
    "detect",
    "extract",
    "field_tracks",
    "input_scale",
    "iter_detect",
    "parse_heard",
    "peak_strengths",
    "sample_stats",
    "sample_steps",
    "steady_anchors",
    "steady_strength",
    "step_strengths",
    "strength_stats",
    "valid_mask",
    "warn_fraction",
]
