"""The report's contact-battery line (:func:`.stability_table.battery_line`), after the stability table."""
from __future__ import annotations

from .stability_table import run_battery as run

TITLE = "contact battery"
TIMED = False

__all__ = ["run", "TITLE", "TIMED"]
