"""
A scene: the explosion with sparks
==================================

Sound models mix in one scene: each says what it *emits* and the engine
propagates all of them along one listener path, with the same retarded time,
distance law, Doppler and panning, so models made by different plugins sit in
one acoustic space.  Here the explosion's field (the data, as ``auralize
render`` hears them) is joined by three discharges of the ``spark`` plugin
(paper 002's WM-waves, the spark-balls preset) at the origin, a corner of the
explosion's box, as ``auralize render DATA --model ...`` mixes models on the
command line.
"""

import matplotlib.pyplot as plt
import numpy as np

from auralize.simple import (
    AddSoundModel,
    CreateListenerPath,
    OpenDataFile,
    RenderAudio,
    ResetSession,
    SaveAudio,
)

ResetSession()
explosion = OpenDataFile("dataset:explosion", size=24, steps=30)
path = CreateListenerPath("orbit", radius=14.0, duration=4.0)
for t0, seed in ((0.9, 1), (1.8, 2), (3.0, 3)):
    AddSoundModel("spark", None, preset="spark-balls", t0=t0, seed=seed)
scene = RenderAudio(layout="stereo")
print(scene)
for part in scene.meta["parts"]:
    print(f"{part['model']:6} {part['kind']:14} peak {part['peak_pa']:.3g} Pa")
SaveAudio("scene.wav", scene)

# %%
# Each crack arrives when its wave has crossed the distance from the corner to
# the listener on the orbit (emitted at 0.9, 1.8 and 3.0 s), a broadband click
# over the explosion's rumble.  The level of each channel per 20 ms, and the
# left channel's spectrogram:

rate = scene.rate
n = rate // 50


def level(p):
    """Level of each 20 ms block, dB re 20 µPa."""
    k = p.shape[-1] // n
    ms = np.mean(p[: k * n].reshape(k, n) ** 2, axis=1)
    return 10 * np.log10(np.maximum(ms, 1e-14) / 20e-6**2)


t = (np.arange(scene.audio.shape[1] // n) + 0.5) * n / rate
fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 5), sharex=True, layout="constrained")
for ch, name in enumerate(scene.layout.channel_names):
    top.plot(t, level(scene.audio[ch]), lw=1, label=name)
top.set(ylabel="level (dB re 20 µPa)", title="The explosion and three sparks")
top.legend(ncols=2, fontsize=8)
bottom.specgram(scene.audio[0], NFFT=1024, Fs=rate, noverlap=768, cmap="magma", vmin=-80)
bottom.set(xlabel="playback time (s)", ylabel="frequency (Hz)", ylim=(0, 8000))
plt.show()
