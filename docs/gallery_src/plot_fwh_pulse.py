"""
Data that hold sound: FW-H against the volume sum
=================================================

A compressible simulation that resolves acoustics stores the sound waves
themselves.  Here the stored field is exact: a Gaussian pulse of volume flow
from a point near the middle of a 41³ grid (±1 m), its linear pressure,
density and velocity at 85 steps of 0.15 ms.  Heard 40 m away, the
Ffowcs Williams–Hawkings integral over a box around the source (Farassat's
formulation 1A, :mod:`auralize.fwh`) gives the pulse's closed-form pressure;
the volume sum of the whole field — right for data whose sources are *in*
the volume — hears the stored waves as sources and gets the far field wrong.
``auralize render`` tells the two kinds of data apart by itself
(:func:`auralize.fwh.classify.wave_test`) and takes FW-H here.
"""

import matplotlib.pyplot as plt
import numpy as np

from auralize.fwh.analytic import Pulse, pulse_field, pulse_volume
from auralize.fwh.classify import wave_test
from auralize.pipeline import auralize
from auralize.spectrum import observer_pressure

source = (0.013, -0.007, 0.011)
vol = pulse_volume("monopole", source)
print(vol)
print(wave_test(vol))

# %%
# The pressure 40 m away along x at 100 kHz, in the data's own time (time scale
# 1, the ``physical`` timbre, no high-pass): through a box 0.6 m around the
# source, and by the volume sum of every point (``method="volume"`` overrides
# the automatic choice).

listener = np.array([40.0, 0.0, 0.0])
rate = 100_000
box = "box=-0.6;0.6;-0.6;0.6;-0.6;0.6"
p_fwh, how = observer_pressure(vol, listener, method="fwh", surface=box, rate=rate)
summed, _ = auralize(
    vol,
    listener=listener,
    rate=rate,
    time_scale=1.0,
    timbre="physical",
    highpass_hz=0.0,
    layout="mono",
    method="volume",
)
p_vol = summed.audio
print(how, "|", summed.meta["method_text"])

# %%
# Each method's signal starts at its own time (FW-H: the window every panel's
# retarded time covers; the volume sum: when the first sound arrives), so each
# is laid on the exact pulse by its best lag before the two are compared.

pulse = Pulse()
t_exact = np.arange(0.10, 0.13, 1 / rate)
p_exact = pulse_field("monopole", source, t_exact, listener, pulse)[0]


def aligned(p):
    """``p`` shifted by the lag that best matches the exact pulse (samples)."""
    p = np.asarray(p).ravel()
    corr = np.correlate(p_exact, p, mode="full")
    lag = int(np.argmax(np.abs(corr))) - (len(p) - 1)
    out = np.zeros_like(p_exact)
    lo, hi = max(lag, 0), min(len(p_exact), lag + len(p))
    out[lo:hi] = p[lo - lag : hi - lag]
    return out


fwh, volsum = aligned(p_fwh), aligned(p_vol)
peak = np.abs(p_exact).max()
for name, p in (("FW-H", fwh), ("volume sum", volsum)):
    err = np.sqrt(np.mean((p - p_exact) ** 2)) / np.sqrt(np.mean(p_exact**2))
    print(f"{name:11} peak {np.abs(p).max() / peak:.3f} × the exact, RMS error {100 * err:.2f} %")

# %%
# FW-H lies on the exact pulse.  The volume sum (right, on its own scale) is
# the sound of the field's *sources*: the stored waves obey the wave equation,
# so Lighthill's stress and the continuity residual of a linear wave are
# nearly nothing, and what is left is not the pulse.

ms = 1e3 * t_exact
centre = ms[np.argmax(np.abs(p_exact))]
fig, (left, right) = plt.subplots(1, 2, figsize=(9, 3.4), layout="constrained")
left.plot(ms, 1e3 * p_exact, color="black", lw=4, alpha=0.3, label="exact")
left.plot(ms, 1e3 * fwh, color="tab:blue", label="FW-H on a box")
left.set(
    xlabel="time at the listener (ms)",
    ylabel="pressure (mPa)",
    title="FW-H",
    xlim=(centre - 3, centre + 3),
)
left.legend()
right.plot(ms, 1e6 * volsum, color="tab:red")
right.set(
    xlabel="time at the listener (ms)",
    ylabel="pressure (µPa)",
    title="volume sum",
    xlim=(centre - 3, centre + 3),
)
fig.suptitle("A stored pulse heard 40 m away")
plt.show()
