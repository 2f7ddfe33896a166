"""``python -m castrajectory.cli``: the console command."""
import sys

from . import main

sys.exit(main())
