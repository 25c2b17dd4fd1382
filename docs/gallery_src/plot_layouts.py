"""
One sound, five layouts
=======================

The same render of the explosion — the default orbit, whose head turns so
that the data pass twice around it — on stereo, 5.1, 7.1, an 8-speaker ring and
two ears.  Every layout pans with its own law (pairwise VBAP on the horizontal
rings, the spherical-head model for ``binaural``), so each speaker's share of
the energy follows where the data were while the listener turned.  The polar
plots place each speaker at its azimuth (0° front, counter-clockwise, as
``auralize`` counts) with a bar as long as its level relative to the loudest.
"""

import matplotlib.pyplot as plt
import numpy as np

import auralize
from auralize.pipeline import save_rendered

vol = auralize.open("dataset:explosion", size=20, steps=24)
renders = {
    name: auralize.render(vol, layout=name, duration=4.0)
    for name in ("stereo", "5.1", "7.1", "ring8", "binaural")
}
for name, r in renders.items():
    print(f"{name:9} {r.layout.channel_names}")

# %%
# Channel levels relative to the loudest channel of each layout (the LFE channel
# of 5.1 and 7.1 carries nothing: nothing is panned to it).

fig, axes = plt.subplots(
    1, 4, figsize=(11, 3.2), subplot_kw={"projection": "polar"}, layout="constrained"
)
for ax, name in zip(axes, ("stereo", "5.1", "7.1", "ring8"), strict=True):
    r = renders[name]
    energy = np.sum(r.audio**2, axis=1)
    db = 10 * np.log10(np.maximum(energy / energy.max(), 1e-6))
    for sp, level in zip(r.layout.speakers, db, strict=True):
        if sp.azimuth_deg is None:  # LFE
            continue
        az = np.radians(sp.azimuth_deg)
        ax.bar(az, 30 + max(level, -30), width=0.35, bottom=0, color="tab:blue", alpha=0.7)
        ax.annotate(sp.name, (az, 33), ha="center", va="center", fontsize=8)
    ax.set_theta_zero_location("N")  # front up, azimuth counter-clockwise
    ax.set_ylim(0, 36)
    ax.set_yticks([10, 20, 30], ["−20", "−10", "0 dB"], fontsize=7)
    ax.set_rlabel_position(200)
    ax.set_xticks([])
    ax.set_title(name, pad=12)
plt.show()

# %%
# The two ears: level differences and a time difference of up to about 0.65 ms
# come from the head's geometry (each ear a receiver of its own).  The binaural
# render, for headphones:

ears = renders["binaural"]
db = 10 * np.log10(np.sum(ears.audio**2, axis=1) / np.sum(ears.audio**2))
print(
    "share of the energy (dB):",
    dict(zip(ears.layout.channel_names, [round(float(v), 1) for v in db], strict=True)),
)
save_rendered(ears, "explosion_binaural.wav", subtype="pcm16")

# %%
# and the 8-speaker ring, one channel per speaker (a browser plays it folded
# down; a multichannel player routes it to a ring of loudspeakers):

save_rendered(renders["ring8"], "explosion_ring8.wav", subtype="pcm16")
