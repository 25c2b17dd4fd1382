"""The ``auralize`` command.

* :mod:`auralize.cli.core` — the parser, the core commands and :func:`main`;
* :mod:`auralize.cli.options` — the shared options every command that
  writes audio takes (core and plugins; plugins receive them as the
  argument of their command hooks);
* one module per command group: :mod:`~auralize.cli.audio` (play, devices),
  :mod:`~auralize.cli.view`, :mod:`~auralize.cli.distributed` (Dask),
  :mod:`~auralize.cli.warmup`, :mod:`~auralize.cli.convert`;
* :mod:`auralize.cli.plugin_commands` — the plugins' sub-commands;
* :mod:`auralize.cli.console` — log and warning output.
"""

from auralize.runtime.lazy import lazy_exports

#: exported name -> sub-module, imported on first access
_EXPORTS = {
    "EXIT_SILENT": ".core",
    "EXIT_USAGE": ".core",
    "EXIT_DATA": ".core",
    "EXIT_SYSTEM": ".core",
    "EXIT_INTERNAL": ".core",
    "EXIT_INTERRUPTED": ".core",
    "EXIT_CODES": ".core",
    "add_detect_options": ".core",
    "add_render_options": ".core",
    "FRAME_WORK_ARRAYS": ".core",
    "check_volume_memory": ".core",
    "check_render_memory": ".core",
    "cmd_info": ".core",
    "cmd_dataset": ".core",
    "cmd_detect": ".core",
    "add_scene_options": ".core",
    "scene_from_args": ".core",
    "cmd_render": ".core",
    "cmd_path": ".core",
    "cmd_plugins": ".core",
    "cmd_demo": ".core",
    "cmd_bench": ".core",
    "build_parser": ".core",
    "CORE_COMMAND_MODULES": ".core",
    "exit_code": ".core",
    "error_message": ".core",
    "main": ".core",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = [
    "CORE_COMMAND_MODULES",
    "EXIT_CODES",
    "EXIT_DATA",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_SILENT",
    "EXIT_SYSTEM",
    "EXIT_USAGE",
    "FRAME_WORK_ARRAYS",
    "add_detect_options",
    "add_render_options",
    "add_scene_options",
    "build_parser",
    "check_render_memory",
    "check_volume_memory",
    "cmd_bench",
    "cmd_dataset",
    "cmd_demo",
    "cmd_detect",
    "cmd_info",
    "cmd_path",
    "cmd_plugins",
    "cmd_render",
    "error_message",
    "exit_code",
    "main",
    "scene_from_args",
]
