"""Physical constants of air shared by the core and the plugins (the bottom layer:
it imports nothing, so the mapping, the layouts and the engine all depend on it
rather than on each other).

Examples
--------
>>> from auralize.constants import C0, RHO0
>>> C0, RHO0
(343.0, 1.2)
"""

#: speed of sound in air (m/s): the one default of the core and the plugins
C0 = 343.0
#: density of air (kg/m³)
RHO0 = 1.2

__all__ = ["C0", "RHO0"]
