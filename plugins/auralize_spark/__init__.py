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

from .field import ChargeScene, ElectricField, field_from_volume, solve_field, solve_laplace
from .leader import Discharge, grow_leader
from .live import ContinuousResult, Delivery, LiveDischarges, continuous_discharges
from .model import SparkResult, SparkSound, charge_glyphs, discharge_mesh, resolve_source, simulate
from .presets import PRESETS, Preset, get_preset
from .waves import (
    SIGMA0,
    Emissions,
    Rendered,
    WaveParams,
    emissions,
    nwave_params,
    render_discharge,
    stroke_times,
    wm_coefficients,
    wm_wave,
)

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
