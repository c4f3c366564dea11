"""Running a model: cases (a model with its scenario), a run's specification, the consistent
start, simulation, collection of the driving functions at the saved samples, results files,
linear models and the stable inversion written as results."""
