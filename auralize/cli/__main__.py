"""``python -m auralize.cli``: the ``auralize`` command."""

import sys

from auralize.cli.core import main

sys.exit(main())
