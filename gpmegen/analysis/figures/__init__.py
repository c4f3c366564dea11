"""Figures and animations of runs, the modal analysis' tables and figures, the list of the
figures ``plot`` and ``demo`` write, and the geometry of the arm they draw."""
