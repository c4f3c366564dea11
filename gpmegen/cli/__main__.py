"""``python -m gpmegen.cli``: the command line, as the ``gpmegen`` console command runs it."""
import sys

from . import main, quick_exit

sys.exit(quick_exit(main()))
