"""What is computed from a loaded model and its states, without running anything: the energy
balance, modes and their kinds, the driving functions, closures' reactions, point motion, the
joint limits passed, the feedforward of prescribed motion, beam theory and Richardson
extrapolation."""
