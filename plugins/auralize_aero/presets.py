"""Presets and examples from paper 004 §8.

* ``cylinder`` / ``square``: D = 1 cm, L = 50 cm sticks (§8.1), 16 sources at 3D.
* ``sword``: a 70 cm blade, 10 point sources (Fig. 9).
* ``sphere``: a 5 cm-radius sphere whirled on a 1 m string, 4 turns (Fig. 11).
  Our textures are 2-D, so the sphere is one point source with the circle
  texture of its diameter and a span of one diameter — an approximation of
  the paper's 3-D texture (§5.2.1).
* ``fence``: vertical cylinders in a wintry wind (Fig. 14).
* motions: :meth:`Motion.swing` (swinging stick), :meth:`Motion.circle`,
  :meth:`Motion.linear` (thrown cylinder, Fig. 12).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from auralize.errors import ParameterError

from .objects import AeroObject, Motion, Wind
from .shapes import Section, circle, square, sword


def stick(length: float = 0.5, diameter: float = 0.01, *, name: str = "stick") -> AeroObject:
    """A straight stick from its grip (origin) along +x; sources every 3D (§7.1)."""
    if not length > 0:
        raise ParameterError(f"length must be > 0 m, got {length!r}")
    return AeroObject([np.array([[0.0, 0, 0], [length, 0, 0]])], diameter, name=name)


def sword_object(length: float = 0.7, thickness: float = 0.005) -> AeroObject:
    """A 70 cm sword along +x with its blade chord along the object's z axis, 10 sources (Fig. 9)."""
    return AeroObject(
        [np.array([[0.0, 0, 0], [length, 0, 0]])],
        thickness,
        reference=np.array([0.0, 1.0, 0.0]),
        spacing=length / 10,
        name="sword",
    )


def fence(
    n_posts: int = 8, height: float = 1.0, gap: float = 0.15, diameter: float = 0.01
) -> AeroObject:
    """Vertical cylinders along +y, spaced ``gap`` (Fig. 14)."""
    if n_posts < 1:
        raise ParameterError(f"a fence needs at least one post, got {n_posts!r}")
    lines = [np.array([[0.0, k * gap, 0], [0.0, k * gap, height]]) for k in range(n_posts)]
    return AeroObject(lines, diameter, reference=np.array([1.0, 0, 0]), name="fence")


def sphere_object(radius: float = 0.05) -> AeroObject:
    """One point source of span 2r at the object origin (see module note)."""
    d = 2 * radius
    return AeroObject(
        [np.array([[0.0, 0, -radius], [0.0, 0, radius]])], d, spacing=d, name="sphere"
    )


@dataclass(frozen=True)
class Preset:
    """A §8 example: the section to texture, the object, and how it moves."""

    name: str
    section: Section
    obj: AeroObject
    motion: Motion | None
    wind: Wind | None
    listener: tuple[float, float, float]
    duration: float
    doc: str


def get_preset(name: str, *, duration: float | None = None, seed: int = 0) -> Preset:
    """``cylinder``, ``square``, ``sword``, ``sphere``, ``fence`` or ``throw`` (§8)."""
    d = 2.0 if duration is None else float(duration)
    if name in ("cylinder", "square"):
        sec = circle(0.01) if name == "cylinder" else square(0.01)
        return Preset(
            name,
            sec,
            stick(0.5, 0.01, name=name),
            Motion.swing(duration=d, swings=d, amplitude_deg=70.0),
            None,
            (0.3, 1.0, 0.2),
            d,
            "§8.1: 50 cm stick of 1 cm section swung by hand",
        )
    if name == "sword":
        return Preset(
            name,
            sword(0.005),
            sword_object(),
            Motion.swing(duration=d, swings=d / 1.5, amplitude_deg=80.0, axis=(0, 0, 1)),
            None,
            (0.4, 1.2, 0.0),
            d,
            "Fig. 9: 70 cm sword, 10 sources",
        )
    if name == "sphere":
        return Preset(
            name,
            circle(0.1),
            sphere_object(0.05),
            Motion.circle(radius=1.0, turns=4, duration=d),
            None,
            (3.0, 0.0, 0.0),
            d,
            "Fig. 11: sphere (r = 5 cm) whirled 4 times on a 1 m string",
        )
    if name == "fence":
        return Preset(
            name,
            circle(0.01),
            fence(),
            None,
            Wind(12.0, (1.0, 0.0, 0.0), gust=0.08, seed=seed),
            (2.0, 3.0, 1.0),
            d,
            "Fig. 14: cold wintry wind through a fence of cylinders",
        )
    if name == "throw":
        # the stick flies across its own axis (vertical): a flow along the axis sheds nothing
        thrown = AeroObject([np.array([[0.0, 0, -0.25], [0.0, 0, 0.25]])], 0.01, name=name)
        return Preset(
            name,
            circle(0.01),
            thrown,
            Motion.linear((-15.0, 0.0, 0.0), (15.0, 0.0, 0.0), duration=d),
            None,
            (15.0, 0.5, 0.0),
            d,
            "Fig. 12: a cylinder thrown at the receiver",
        )
    raise ParameterError(f"unknown preset {name!r}; choose one of {PRESETS}")


PRESETS = ("cylinder", "square", "sword", "sphere", "fence", "throw")


def describe_presets() -> list[dict[str, Any]]:
    return [{"name": n, "doc": get_preset(n).doc} for n in PRESETS]
