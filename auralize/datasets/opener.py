"""Opening a volume by name: a file, or a dataset that comes with auralize (``dataset:NAME``).

The one opener of every front end (:func:`auralize.pipeline.load` is this
:func:`load`) and of the sound models whose input is a volume
(:func:`auralize.plugins.load_volume_input`): it sits below both, above the
readers (:mod:`auralize.io`) and the datasets it names.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from auralize.datasets.synthetic import make_dataset
from auralize.errors import ParameterError
from auralize.volume import TimeVolume

__all__ = ["load"]


def load(
    spec: str | Path | TimeVolume,
    *,
    size: int | None = None,
    steps: int | None = None,
    seed: int = 0,
    fields: dict[str, str] | None = None,
    resolution: int | tuple[int, int, int] | None = None,
    nan: Literal["mask", "error"] = "mask",
    time_dim: str | None = None,
    axis_scale: Any = None,
    box: Any = None,
) -> TimeVolume:
    """Open a volume file, or a dataset that comes with auralize by ``"dataset:NAME"``:
    generated (``size``, ``steps``, ``seed``) or shipped (``dataset:cavity``, ...;
    :mod:`auralize.datasets.shipped`).

    ``nan`` (``"mask"`` or ``"error"``) is what NaN, fill values and masked
    cells in a file are; ``time_dim``, ``axis_scale`` and ``box`` are the
    readers' options; see :func:`auralize.io.open_volume`.
    """
    if isinstance(spec, TimeVolume):
        return spec
    s = str(spec)
    from auralize.io import open_volume

    if s.startswith("dataset:"):
        from auralize.datasets.shipped import SHIPPED, shipped_path

        name = s.split(":", 1)[1]
        if name not in SHIPPED:
            from auralize.io.options import ReadOptions, check_axis_scale, check_box, finish

            if time_dim is not None:
                raise ParameterError(
                    f"dataset:{name} is generated; time_dim (--time-dim) "
                    f"names a netCDF file's time dimension"
                )
            vol = make_dataset(name, size=size, steps=steps, seed=seed)
            return finish(
                vol,
                ReadOptions(
                    axis_scale=check_axis_scale(axis_scale, source=s), box=check_box(box, source=s)
                ),
            )
        if size is not None or steps is not None:
            raise ParameterError(
                f"dataset:{name} is a shipped file ({SHIPPED[name][1]}); "
                f"--size and --steps apply to generated datasets"
            )
        return open_volume(
            shipped_path(name),
            fields=fields,
            resolution=resolution,
            nan=nan,
            time_dim=time_dim,
            axis_scale=axis_scale,
            box=box,
        )

    return open_volume(
        s,
        fields=fields,
        resolution=resolution,
        nan=nan,
        time_dim=time_dim,
        axis_scale=axis_scale,
        box=box,
    )
