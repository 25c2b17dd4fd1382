"""FireSound: the fire-sound SoundModel (paper 001), its CLI, benchmark and overlay."""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from auralize.emitters import Emitters, Sound
from auralize.errors import ParameterError
from auralize.plugins import Parameter, SoundModel
from auralize.volume import TimeVolume
from auralize_fire.bandwidth import bandwidth_extend, check_signal
from auralize_fire.clips import fire_training_clip, read_audio, resample
from auralize_fire.dataset import make_fire
from auralize_fire.lowfreq import flux_series, front_at, lowfreq_pressure
from auralize_fire.texture import texture_extend

SHARED = Path(__file__).resolve().parents[3] / "shared" / "datasets" / "fire-lowfreq"
#: ρ0 / (4π) (kg/m³): pressure at 1 m of a volume source, p = ρ0/(4π r) · dI/dt
MONOPOLE_1M = 1.2 / (4.0 * np.pi)


def render_chain(  # noqa: PLR0913 (keyword-only options)
    volume: TimeVolume,
    *,
    extend: str = "bandwidth",
    rate: int = 44100,
    burn_field: str = "burn",
    velocity_field: str = "velocity",
    iso: float | None = None,
    refine: int = 2,
    highpass_hz: float = 30.0,
    alpha: float = 3.0,
    f_cut: float = 180.0,
    levels: int = 6,
    eps: float = 1.0,
    coarse_weight: float = 3.0,
    training: NDArray[np.floating] | None = None,
    seed: int = 0,
) -> tuple[NDArray[np.float64], Any]:
    """§3 → §6 high-pass → §4 or §5: the emitted fire sound of a volume.

    Returns ``(signal (n,), FluxSeries)``, the signal in the units of
    :func:`auralize_fire.lowfreq.lowfreq_pressure` (m³/s²) whichever
    ``extend``: ``"none"``, ``"bandwidth"`` (§4, keeps its input's units) or
    ``"texture"`` (§5 by :func:`auralize_fire.texture.texture_extend`: the
    texture rescaled so that its band below ``f_cut`` has the low-frequency
    signal's RMS; ``training`` at ``rate``, default: the procedural clip, 15 s;
    ``levels``, ``eps`` and ``coarse_weight`` as :func:`auralize_fire.texture.texture_synthesize`).
    """
    if extend not in ("none", "bandwidth", "texture"):
        raise ParameterError(f"extend must be 'none', 'bandwidth' or 'texture', got {extend!r}")
    fs = flux_series(
        volume, burn_field=burn_field, velocity_field=velocity_field, iso=iso, refine=refine
    )
    low = lowfreq_pressure(fs, rate=rate, highpass_hz=highpass_hz)
    if extend == "none":
        return low, fs
    if extend == "bandwidth":
        return bandwidth_extend(low, rate, alpha=alpha, f_cut=f_cut, seed=seed), fs
    clip = fire_training_clip(15.0, rate, seed=seed) if training is None else training
    return (
        texture_extend(
            low, clip, rate, f_cut=f_cut, levels=levels, eps=eps, coarse_weight=coarse_weight
        ),
        fs,
    )


def fire_sound(  # noqa: PLR0913 (keyword-only options)
    volume: TimeVolume,
    *,
    extend: str = "bandwidth",
    rate: int = 44100,
    burn_field: str = "burn",
    velocity_field: str = "velocity",
    iso: float | None = None,
    refine: int = 2,
    highpass_hz: float = 30.0,
    alpha: float = 3.0,
    f_cut: float = 180.0,
    levels: int = 6,
    eps: float = 1.0,
    coarse_weight: float = 3.0,
    training: NDArray[np.floating] | None = None,
    seed: int = 0,
    t0: float = 0.0,
) -> Sound:
    """The fire of ``volume`` as one point emitter at its flame front (paper 001 §3–§5).

    The emitted signal is the chain of :func:`render_chain` scaled to the
    pressure at 1 m of a volume source whose volume flow is the front flux I:
    ``p_1m = ρ0/(4π) · dI/dt`` (the constant §3.1 omits; ρ0 = 1.2 kg/m³), in Pa.
    The emitter sits at the front's area-weighted centre, moving with it
    (linear between steps, sampled at ``rate``) or static when the centre
    does not move.  Propagation, distance law, Doppler and panning are the
    engine's (:func:`auralize.emitters.render_sound`).

    Parameters
    ----------
    volume : TimeVolume with the burn and velocity fields.
    extend, rate, burn_field, velocity_field, iso, refine, highpass_hz, alpha,
    f_cut, levels, eps, coarse_weight, training, seed : see :func:`render_chain`.
    t0 : s, playback time (since the listener path's first capture) of the
        volume's first step.

    Returns
    -------
    Sound with one :class:`auralize.emitters.Emitters` (monopole, ``(1, n)`` Pa
    at 1 m at ``rate`` from ``t0``).
    """
    if not isinstance(volume, TimeVolume):
        raise ParameterError(f"fire model inputs must be a TimeVolume, got {type(volume).__name__}")
    sig, fs = render_chain(
        volume,
        extend=extend,
        rate=rate,
        burn_field=burn_field,
        velocity_field=velocity_field,
        iso=iso,
        refine=refine,
        highpass_hz=highpass_hz,
        alpha=alpha,
        f_cut=f_cut,
        levels=levels,
        eps=eps,
        coarse_weight=coarse_weight,
        training=training,
        seed=seed,
    )
    ok = fs.area > 0
    moving = bool(np.ptp(fs.centroid[ok], axis=0).max() > 0)
    pos = trajectory(fs, sig.size, rate)[None] if moving else fs.centroid[ok][:1]
    em = Emitters(
        sig[None] * MONOPOLE_1M,
        rate,
        pos,
        t0=t0,
        name="fire",
        meta={"source": "flame-front centre"},
    )
    meta = {
        "model": "fire",
        "iso": fs.iso,
        "flux": fs.flux,
        "front_area": fs.area,
        "extend": extend,
        "moving": moving,
        "emitter_units": "Pa at 1 m",
    }
    return Sound([em], meta=meta, name="fire")


class FireSound(SoundModel):
    """Fire sound from flame-front flux with bandwidth extension or textures (paper 001).

    ``synthesize(volume, **params)`` returns an :class:`auralize.emitters.Sound`
    with the flame as one point emitter (:func:`fire_sound`); render it along
    a listener path with :func:`auralize.emitters.render_sound`.
    """

    name: ClassVar[str] = "fire"
    description: ClassVar[str] = (
        "fire sound: flame-front velocity flux, spectral bandwidth extension or texture synthesis"
    )
    paper: ClassVar[str] = "001 §3–§5"
    parameters: ClassVar[tuple[Parameter, ...]] = (
        Parameter("burn_field", "burn", doc="scalar field whose iso-surface is the front (§3.2)"),
        Parameter("velocity_field", "velocity", doc="vector field u (m/s)"),
        Parameter("iso", None, doc="front iso-value (default 10 % of the peak)"),
        Parameter("refine", 2, range=(1, 8), doc="B-spline refinement per voxel (Eq. 7)"),
        Parameter("extend", "bandwidth", choices=("none", "bandwidth", "texture")),
        Parameter("highpass_hz", 30.0, range=(0.0, 1000.0), unit="Hz", doc="§6 high-pass"),
        Parameter("alpha", 3.0, range=(0.5, 6.0), doc="power-law exponent (§4, Table 1)"),
        Parameter(
            "f_cut",
            180.0,
            range=(20.0, 5000.0),
            unit="Hz",
            doc="blend centre (Table 1); texture: top of the level-matched band",
        ),
        Parameter("levels", 6, range=(2, 10), doc="pyramid levels L (§5)"),
        Parameter("eps", 1.0, range=(0.0, 10.0), doc="approximate-NN ε (§5.2)"),
        Parameter(
            "coarse_weight", 3.0, range=(0.0, 100.0), doc="weight of the Eq. 16 feature samples"
        ),
        Parameter("seed", 0, range=(0, None)),
        Parameter("rate", 44100, range=(8000, 192000), unit="Hz", doc="emitted signal's rate"),
        Parameter("t0", 0.0, range=(None, None), unit="s", doc="playback time of the first step"),
    )
    datasets: ClassVar[dict[str, Any]] = {"fire": make_fire}

    def synthesize(self, inputs: Any, **params: Any) -> Sound:
        """The fire of a volume (no listener: render the Sound along a path).

        Parameters
        ----------
        inputs : TimeVolume with the ``burn_field`` and ``velocity_field``.
        **params : the model's :attr:`parameters`.

        Returns
        -------
        Sound with one monopole :class:`auralize.emitters.Emitters` (Pa at 1 m).
        """
        p = self.resolve(**params)
        if isinstance(inputs, tuple):
            raise ParameterError(
                "fire inputs are the TimeVolume only, without a listener: render the returned "
                "Sound along a path with auralize.pipeline.render"
            )
        return fire_sound(
            inputs,
            extend=p["extend"],
            rate=int(p["rate"]),
            burn_field=p["burn_field"],
            velocity_field=p["velocity_field"],
            iso=p["iso"],
            refine=int(p["refine"]),
            highpass_hz=p["highpass_hz"],
            alpha=p["alpha"],
            f_cut=p["f_cut"],
            levels=int(p["levels"]),
            eps=p["eps"],
            coarse_weight=p["coarse_weight"],
            seed=int(p["seed"]),
            t0=float(p["t0"]),
        )

    def warm_up(self) -> None:
        """Compile the fire kernels on a small fire (``auralize warmup --plugins``): the
        flame front and flux, and the texture synthesis's kd-tree and search."""
        from auralize_fire.clips import fire_training_clip
        from auralize_fire.texture import texture_synthesize

        self.synthesize(make_fire(size=12, steps=12), extend="none")
        rng = np.random.default_rng(0)
        texture_synthesize(rng.normal(size=256), fire_training_clip(0.05, 8000, seed=0), levels=2)

    def overlay(self, inputs: Any, step: int) -> Any:
        """The flame front at ``step`` as pyvista PolyData, cell scalars ``u_dot_n`` (m/s)."""
        volume = inputs[0] if isinstance(inputs, tuple) else inputs
        burn, vel = "burn", "velocity"
        from auralize_fire.lowfreq import check_fields, default_iso

        check_fields(volume, burn, vel)
        front = front_at(volume, step, burn_field=burn, iso=default_iso(volume, burn))
        mesh = front.to_pyvista()
        mesh.cell_data["u_dot_n"] = front.u_dot_n(
            volume.frame(vel, step), volume.origin, volume.spacing
        )
        mesh.set_active_scalars("u_dot_n", preference="cell")
        return mesh

    @classmethod
    def add_cli(cls, subparsers: Any, options: Any) -> None:
        from auralize_fire.cli import add_fire_cli

        add_fire_cli(subparsers, options)

    @classmethod
    def bench(cls, quick: bool) -> list[Any]:
        from auralize_fire.benchmark import fire_bench

        return fire_bench(quick)


def trajectory(fs: Any, n: int, rate: int) -> NDArray[np.float64]:
    """Front centre per audio sample (n, 3), linear between the steps that have a front."""
    ok = fs.area > 0
    t = np.arange(n) / rate + fs.times[0]
    return np.stack([np.interp(t, fs.times[ok], fs.centroid[ok, k]) for k in range(3)], axis=1)


def load_volume(
    spec: str, *, size: int | None = None, steps: int | None = None, seed: int = 0
) -> TimeVolume:
    """A volume file, ``dataset:fire`` or another core dataset."""
    if spec == "dataset:fire":
        kw: dict[str, int] = {"seed": seed}
        if size is not None:
            kw["size"] = size
        if steps is not None:
            kw["steps"] = steps
        return make_fire(**kw)
    from auralize.io.options import curvilinear_mode
    from auralize.pipeline import load

    with curvilinear_mode("resample"):  # the flame front takes uniform spacing
        return load(spec, size=size, steps=steps, seed=seed)


def training_at(
    path: str | None, rate: int, *, seed: int = 0, training_rate: int | None = None
) -> NDArray[np.float64]:
    """Training clip resampled to ``rate`` (default: procedural, 15 s)."""
    if path is None:
        return fire_training_clip(15.0, rate, seed=seed)
    x, r = read_audio(path, rate=training_rate, option="--training-rate")
    return check_signal(resample(x, r, rate), f"training clip {path}")
