"""auralize: hear 3-D time-varying data.

``import auralize`` opens no window and no sound device; the GUI (``auralize.viewer``)
and the audio device layer (``auralize.audio``) are imported only when used.
"""

from auralize.errors import AuralizeError
from auralize.volume import TimeVolume

__version__ = "0.1.0"

__all__ = ["AuralizeError", "TimeVolume", "__version__"]
