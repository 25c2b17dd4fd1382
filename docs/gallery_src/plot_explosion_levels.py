"""
The explosion, heard and measured
=================================

The built-in ``explosion`` dataset (a seeded blast in a 24³ grid) heard along
the default orbit, as ``auralize render`` hears it with no options but the
layout: the whole field summed at its retarded times, the data's time span
fitted into the playback duration.  The sound is written to a WAV file (the
player below), then measured as ``auralize spectrum`` measures it: its level,
second by second, and its ⅓-octave band levels.
"""

import matplotlib.pyplot as plt
import numpy as np

import auralize
from auralize.pipeline import save_rendered
from auralize.spectrum import P_REF, spectrum

vol = auralize.open("dataset:explosion", size=24, steps=30)
print(vol)

# %%
# Render six seconds in stereo.  Its ``meta`` says what was heard
# and how data time maps to playback time.

rendered = auralize.render(vol, layout="stereo", duration=6.0)
print(rendered)
for key in ("heard_text", "time_mapping", "timbre", "listener"):
    print(f"{key:13}", rendered.meta[key])
save_rendered(rendered, "explosion.wav", subtype="pcm16")  # half the size of float32

# %%
# The render is in pascals at the listener.  Its level (dB re 20 µPa) over each
# second of playback, per channel, with the 100 ms level as a line: loudest as
# the blast's front arrives; after that the two channels trade places while the
# listener's head turns on the orbit.

rate = rendered.rate
left_right = rendered.audio
labels = rendered.layout.channel_names


def level(p, n):
    """Equivalent level of each block of ``n`` samples, dB re 20 µPa."""
    k = p.shape[-1] // n
    ms = np.mean(p[..., : k * n].reshape(*p.shape[:-1], k, n) ** 2, axis=-1)
    return 10 * np.log10(np.maximum(ms, 1e-30) / P_REF**2)


per_second = level(left_right, rate)
fine = level(left_right, rate // 10)
fig, ax = plt.subplots(figsize=(7, 3.4), layout="constrained")
seconds = np.arange(per_second.shape[1])
for i, (name, colour) in enumerate(zip(labels, ("tab:blue", "tab:orange"), strict=True)):
    ax.bar(
        seconds + 0.5 + (i - 0.5) * 0.4,
        per_second[i],
        width=0.4,
        color=colour,
        alpha=0.6,
        label=f"{name}, per second",
    )
    ax.plot(
        (np.arange(fine.shape[1]) + 0.5) / 10,
        fine[i],
        color=colour,
        lw=1,
        label=f"{name}, per 100 ms",
    )
ax.set(
    xlabel="playback time (s)",
    ylabel="level (dB re 20 µPa)",
    ylim=(np.floor(fine.max()) - 40, np.ceil(fine.max()) + 3),
)
ax.legend(loc="lower left", bbox_to_anchor=(0, 1.01), ncols=4, fontsize=8, frameon=False)
plt.show()

# %%
# The ⅓-octave band levels of the whole render (IEC 61260-1 centres); the
# overall level and the A-weighted level are in the summary.

s = spectrum(left_right, rate, channels=labels, source="explosion.wav")
print(s)
fig, ax = plt.subplots(figsize=(7, 3.2), layout="constrained")
x = np.arange(len(s.band_centres))
for i, name in enumerate(s.channels):
    ax.step(x, s.band_levels[i], where="mid", label=name)
ax.set_xticks(x[::3], [s.band_labels[j] for j in x[::3]], rotation=45)
ax.set(xlabel="⅓-octave band (Hz)", ylabel="band level (dB re 20 µPa)")
ax.legend()
plt.show()
