"""``python -m gcs``: the same as ``ftc-gcs``."""

import sys

from gcs.cli import main

sys.exit(main())
