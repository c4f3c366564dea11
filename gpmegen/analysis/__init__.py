"""What is done with a loaded model, in subpackages by concern, each importing only those below
it (the order the import contracts in pyproject.toml keep):

- :mod:`~gpmegen.analysis.figures`: figures, animations and the files of the modal analysis;
- :mod:`~gpmegen.analysis.discretization`: one model at several ``n_rfe``, the discretization
  error and its extrapolation;
- :mod:`~gpmegen.analysis.sweep`: many runs of one model with new parameters;
- :mod:`~gpmegen.analysis.export`: the FMU of a case started as a run starts it, its binary compiled;
- :mod:`~gpmegen.analysis.run`: cases, a run's specification, simulation and statics, results files;
- :mod:`~gpmegen.analysis.post`: what is computed from a loaded model and its states (energy,
  modes, driving functions, closures' reactions, beam theory, Richardson extrapolation).
"""

