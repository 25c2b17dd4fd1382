"""``python -m auralize``: the same command as ``auralize``."""

import sys

from auralize.cli import main

sys.exit(main())
