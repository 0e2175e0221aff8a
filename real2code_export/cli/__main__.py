"""``python -m real2code_export.cli ...`` (= ``real2code ...``)."""

from . import main

main()
