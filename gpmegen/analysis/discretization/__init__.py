"""One model at several ``n_rfe`` (levels): runs of the levels, the convergence study of modes and
statics against beam theory, and the Richardson extrapolation of any output."""
