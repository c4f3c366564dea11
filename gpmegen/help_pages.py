"""The help pages of the command line: for each subcommand a description, examples and the
files it writes (``gpmegen COMMAND --help``)."""

from __future__ import annotations

DESCRIPTIONS = {
    "build": """\
Generate the model's code: the derivation (SymPy) rendered as a NumPy module and as C with its
header. Both are always written; the NumPy module is the C one's oracle. Inputs that have not
changed since the last build are skipped unless --force.""",
    "simulate": """\
Find the start (statics, or a model file's [initial] configuration), then integrate the
constrained motion with fixed-step RK4 (the paper's), generalized-alpha (implicit, numerically
damped, any step), DOP853 (adaptive, to --rtol/--atol) or SciPy's Radau. Every method saves every
--dt x --save-every s (or --save-dt). An RK4 step above the stable one of the highest natural
frequency at the start is refused, naming that step. The summary line names how the run ended
(complete, diverged at t, or interrupted: Ctrl-C, exit status 130) and what it took: steps,
rejections, GPME solves, Jacobians, LU factorizations.""",
    "statics": """\
Print the static start configuration: every coordinate, the positions of the points and the
constants the start sets (the reference case's r_Ea and y_c).""",
    "plot": """\
Draw the figures of one or more results files of one model, overlaid: each run keeps its colour
and line style in every figure. Results of different models, or with different constraints, are
refused before any figure is written: plot each group into its own folder.""",
    "modes": """\
Natural frequencies and mode shapes about the static equilibrium of the reference manipulator,
a model file or a folder made by 'build --out', with the joints locked or with the programmed
constraints holding.""",
    "convergence": """\
Clamp the arm (or each flexible link of a model file, alone) at its root and compare its static
tip deflection and first frequencies against the number of rfes with Euler-Bernoulli and
Saint-Venant beam theory.""",
    "invert": """\
Stable inversion of the actuated realization: the bounded inputs that realize a programmed
motion resting before t0 and after t1 when the internal dynamics are unstable (non-minimum
phase), found as a boundary-value problem over [t0 - pre, t1 + post]. Prints how long before t0
the inputs must start and after t1 they act.""",
    "sweep": """\
Many runs of one case: every combination of the given parameter values and rfe counts, or K
samples (Latin hypercube or uniform) within given ranges. Each run is a simulate run (the same
code, the same results file); the runs go to all local cores by default, or to a Dask cluster
with --scheduler. A failed run is recorded with its message and the others go on; run the same
sweep again after an interruption and the runs already complete are kept.""",
    "demo": """\
The paper's study: the rigid (n_rfe = 1) and flexible (n_rfe = 5) arms, 10 s of constrained
motion from the locked-joint statics, and their figures.""",
}

EPILOGS = {
    "build": """\
examples:
  gpmegen build --nrfe 5
  gpmegen build --nrfe 1 5 20 --force
  gpmegen build examples/planar_two_link.toml --out my_models

files written:
  <out>/<model>/model_numpy.py, model.c, model.h, manifest.json   (default out: generated/)""",
    "simulate": """\
examples:
  gpmegen simulate --nrfe 5 --t-end 10 --dt 1e-5
  gpmegen simulate --nrfe 5 --statics constrained --out results/constrained.npz
  gpmegen simulate generated/my_arm                (a folder made by 'build --out')
  gpmegen simulate --nrfe 1 --method dop853
  gpmegen simulate --nrfe 5 --method dop853 --rtol 1e-9 --save-dt 1e-3
  gpmegen simulate --nrfe 5 --method genalpha --dt 2e-4 --rho-inf 0.9
  gpmegen simulate --nrfe 5 --param tdr0=2*pi --param d2=0.01
  gpmegen simulate --nrfe 1 --actuated psi2 x3     (inputs on psi2 and x3 realize the constraints)
  gpmegen simulate examples/planar_two_link.toml --t-end 4 --out results/planar.npz
  gpmegen simulate examples/spinup.toml --nrfe 5 10 20 --extrapolate --t-end 20 --dt 1e-4

files written:
  results/<run_nrfe<N> or the model file's name>_<start>_<method>[_actuated-<coordinates>].npz
  and .csv, or --out and its .csv; an existing results file is refused unless --overwrite; a run that diverges or is
  interrupted writes <name>.partial.npz and .csv instead and leaves a complete <name>.npz as it
  was; with --extrapolate, <out>_nrfe<N>.npz for each level and the extrapolation in
  results/<name>_extrapolated.npz (or --out) with its figure .png""",
    "statics": """\
examples:
  gpmegen statics --nrfe 5
  gpmegen statics --nrfe 5 --statics constrained --param g=9.80665
  gpmegen statics examples/planar_two_link.toml --statics locked

files written:
  none (the configuration is printed)""",
    "plot": """\
examples:
  gpmegen plot results/run_nrfe1.npz results/run_nrfe5.npz
  gpmegen plot results/*.npz --out figures/paper --format png,pdf,svg

files written:
  <out>/joint_coordinates, end_effector, path, constraint_violation (when the model has
  constraints) and energy_balance, each as .png (200 dpi), .pdf or .svg (default out: figures/);
  the same input gives the same bytes""",
    "modes": """\
examples:
  gpmegen modes --nrfe 5
  gpmegen modes --nrfe 5 --lock constraints --count 6
  gpmegen modes examples/planar_two_link.toml --nrfe 4

files written:
  <out>/modes_nrfe<N>_<lock>.csv (frequencies and shapes) and .png (the first shapes along the
  arm)   (default out: figures/)""",
    "convergence": """\
examples:
  gpmegen convergence
  gpmegen convergence --nrfe 2 3 5 10 --static nonlinear --directory built/
  gpmegen convergence examples/planar_two_link.toml --param E_al=6.9e10

files written:
  <out>/convergence.png, or convergence_<model>_link<label>.png per flexible link of a model
  file (default out: figures/); with --directory, the clamped-arm models built
  there""",
    "invert": """\
examples:
  gpmegen invert tests/models/flexible_link.toml --nrfe 3 --t1 0.2
  gpmegen invert my_arm.toml --t1 1.5 --pre 0.3 --post 0.3 --out results/arm_inverse.npz

files written:
  results/<case>_inversion.npz and .csv (or --out and its .csv): t, q, qd, the inputs u on the
  actuated coordinates""",
    "sweep": """\
examples:
  gpmegen sweep --nrfe 1 5 --param E2=2e9:2e11:8 --t-end 2.5 --out sweeps/stiffness
  gpmegen sweep examples/planar_two_link.toml --param m2=0.5:2 --samples 32 --seed 1 --t-end 2 --out sweeps/mc
  gpmegen sweep --param E2=7e10,2e11 --t-end 1 --out sweeps/e2 --scheduler tcp://10.0.0.5:8786

files written:
  <out>/sweep.json (the sweep's arguments), <out>/runs/<run id>.npz and .csv (one results file per
  run), <out>/summary.csv and summary.parquet (per-run inputs and scalar outcomes)""",
    "demo": """\
examples:
  gpmegen demo
  gpmegen demo --t-end 2 --results short --figures short/figures

files written:
  <results>/run_nrfe1.npz, run_nrfe5.npz and their .csv (default results/);
  <figures>/joint_coordinates.png, end_effector.png, path.png, constraint_violation.png,
  energy_balance.png (default figures/)""",
}
