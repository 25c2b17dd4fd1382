"""auralize: hear 3-D time-varying data.

``import auralize`` opens no window and no sound device; the GUI (``auralize.viewer``)
and the audio device layer (``auralize.audio``) are imported only when used.
"""

import os

# numba's OpenMP threads must sleep, not spin, between parallel regions: on a
# shared or small machine (and with the GUI, audio and worker threads of the
# viewer) spinning workers steal the cores the other threads need.  Set before
# numba's threading layer starts; a user's own setting wins.
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

from auralize.errors import AuralizeError
from auralize.volume import TimeVolume

__version__ = "0.1.0"

__all__ = ["AuralizeError", "TimeVolume", "__version__"]
