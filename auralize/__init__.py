"""auralize: hear 3-D time-varying data.

``import auralize`` opens no window and no sound device; the GUI (``auralize.viewer``)
and the audio device layer (``auralize.audio.output``) are imported only when used, and
it changes no process-wide setting (the numba kernels' settings apply when a
kernel module is first imported, see :mod:`auralize.runtime.jit`).
"""

from auralize.errors import AuralizeError
from auralize.volume import TimeVolume

__version__ = "0.1.0"

__all__ = ["AuralizeError", "TimeVolume", "__version__"]
