"""Exports that are built from a started case: the FMU (:mod:`~gpmegen.analysis.export.fmu`),
compiled with the runtime's compiler and started as ``gpmegen simulate`` starts the case."""
