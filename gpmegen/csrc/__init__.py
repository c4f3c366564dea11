"""The solver library's C sources (package data): the GPME's dense solve, RK4, DOP853,
generalized-α, Radau IIA and the acceleration Jacobians, compiled once per machine and flags
into the C cache and linked into every model library (:mod:`gpmegen.runtime.ccompile`)."""
