"""The C of gpmegen's FMUs (FMI 2.0, :mod:`gpmegen.codegen.backends.fmu`): the standard's types and
function declarations (``gpmegen_fmi2.h``, written from the FMI 2.0 specification) and the
wrapper that serves them from a model's generated C and the solver library (``gpmegen_fmi2.c``)."""
