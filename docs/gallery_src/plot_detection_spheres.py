"""
Sources and their ΔV spheres
============================

What is *drawn*: paper 003's monopoles, dipoles and quadrupoles, detected at
every vertex and time step of the explosion, each shown as the sphere whose
volume is its share of the source region (ΔV).  The script reads like a
ParaView ``pvpython`` session (:mod:`auralize.simple`): open, detect, show,
screenshot, all off screen.  What is *heard* is the whole field, not these
points (see :doc:`/hearing`); the last block renders it along the orbit shown.
"""

import matplotlib.pyplot as plt
import numpy as np

from auralize.palette import PALETTE
from auralize.simple import (
    CreateListenerPath,
    DetectSources,
    OpenDataFile,
    RenderAudio,
    ResetSession,
    SaveAudio,
    SaveScreenshot,
    Show,
)

ResetSession()
explosion = OpenDataFile("dataset:explosion", size=32, steps=16)
series = DetectSources(monopole="3%", dipole="0.3%", quadrupole="0.1%")
print(series)

# %%
# The sources at the middle step over the volume of the (log) density, and an
# orbit of the listener around the blast; the view frames the data as the
# viewer does when it opens them.

vol = explosion.Volume
radius = 0.6 * float(vol.bounds[1] - vol.bounds[0])
path = CreateListenerPath("orbit", radius=radius, height=0.15 * radius, duration=4.0)
Show(explosion, step=8)
Show(path)
SaveScreenshot("spheres.png", resolution=(960, 640))

# %%
# How many sources of each type every step holds, in the palette every picture
# of them uses (the viewer's, the ``.pvd`` exports' ``rgb`` array, the notebook
# displays).

counts = series.counts()
steps = np.arange(len(counts))
fig, ax = plt.subplots(figsize=(7, 3), layout="constrained")
bottom = np.zeros(len(counts))
for kind, rgb in PALETTE.items():
    n = np.array([c[kind] for c in counts], dtype=float)
    ax.bar(steps, n, bottom=bottom, color=np.array(rgb) / 255, label=kind)
    bottom += n
ax.set(xlabel="time step", ylabel="sources", title="Detected sources per step")
ax.legend()
plt.show()

# %%
# The whole field heard along that orbit, on two ears.

rendered = RenderAudio(layout="binaural")
print(rendered)
SaveAudio("orbit_binaural.wav", rendered)
