"""``python -m real2code_export.batch TASK INPUT... --out DIR`` (= ``real2code batch ...``)."""

import sys

from ..cli.batch import main

sys.exit(main())
