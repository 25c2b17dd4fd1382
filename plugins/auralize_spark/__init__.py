"""auralize_spark: spark-discharge and thunder sound with N-waves and WM-waves (paper 002).

Matsuyama, Fujimoto & Chiba, "Generating spark discharge sound for
interactive animation using WM-wave": a charge scene gives a Laplace field
(§4.1, Eq. 1), a stochastic leader grows through it (Eq. 2), and every
segment of the discharge tree radiates a WM-wave (Eq. 5) built on the
N-wave laws of Eqs. 3–4, summed at the listener at its arrival time
(§4.2.2), for one or several strokes (§4.2.3).  Continuous discharges reuse
waveforms (§4.2.4) and :class:`LiveDischarges` generates sound on a worker
thread (§4.2.1).  Table 1 presets: ``spark-balls``, ``plasma-ball``,
``lightning``.

>>> from auralize_spark import simulate
>>> res = simulate(preset="plasma-ball", seed=1)
>>> res.rendered.rate
44100
"""

from auralize.runtime.lazy import lazy_exports

#: exported name -> sub-module; imported on first access, so that declaring the
#: plugin's sub-commands (``auralize --help``) loads none of its physics
_EXPORTS = {
    "ChargeScene": ".field",
    "ElectricField": ".field",
    "field_from_volume": ".field",
    "solve_field": ".field",
    "solve_laplace": ".field",
    "Discharge": ".leader",
    "grow_leader": ".leader",
    "ContinuousResult": ".live",
    "Delivery": ".live",
    "LiveDischarges": ".live",
    "continuous_discharges": ".live",
    "SparkResult": ".model",
    "SparkSound": ".model",
    "charge_glyphs": ".model",
    "discharge_mesh": ".model",
    "resolve_source": ".model",
    "simulate": ".model",
    "PRESETS": ".presets",
    "Preset": ".presets",
    "get_preset": ".presets",
    "SIGMA0": ".waves",
    "Emissions": ".waves",
    "Rendered": ".waves",
    "WaveParams": ".waves",
    "emissions": ".waves",
    "nwave_params": ".waves",
    "render_discharge": ".waves",
    "stroke_times": ".waves",
    "wm_coefficients": ".waves",
    "wm_wave": ".waves",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = [
    "PRESETS",
    "SIGMA0",
    "ChargeScene",
    "ContinuousResult",
    "Delivery",
    "Discharge",
    "ElectricField",
    "Emissions",
    "LiveDischarges",
    "Preset",
    "Rendered",
    "SparkResult",
    "SparkSound",
    "WaveParams",
    "charge_glyphs",
    "continuous_discharges",
    "discharge_mesh",
    "emissions",
    "field_from_volume",
    "get_preset",
    "grow_leader",
    "nwave_params",
    "render_discharge",
    "resolve_source",
    "simulate",
    "solve_field",
    "solve_laplace",
    "stroke_times",
    "wm_coefficients",
    "wm_wave",
]
