"""Every tolerance of the suite, named, each with the reason for its size.

Tests import them from here (or through tests/support/helpers.py, which builds the
per-dtype bounds of the detectors' geometry from the first group). A literal
in a test that is not from here is not a tolerance (a size, a coordinate, a
step). tests/test_tolerances.py fails on a tolerance keyword given a literal
elsewhere. ``eps``: float32's is 1.2e-7, float64's 2.2e-16.
"""

from __future__ import annotations

import numpy as np

# --- The detectors' geometry, in units of eps of the dtype computed in -------

# Gaps, projections, crossing times: a handful of operations on differences of
# the inputs, each within eps/2 of the local scale (helpers.local_atol).
LOCAL_ULPS = {np.dtype(np.float32): 8, np.dtype(np.float64): 8}
# The exact-oracle bounds (tests/support/exact_checks.py): the same count, per term.
EXACT_ULPS = 8
# A detector's and the dense form's gradients of one pair: two programs that
# contract into fused multiply-adds differently (1e-12 in float64).
GRADIENT_EPS = 4500
# The per-pair kernel in the dense and the binned program: XLA fuses a*b+c
# differently per fusion, a few ulps of the coordinates' scale.
BINNED_ULPS = 16

# The 3D oracle (tests/support/oracle3d.py) against all_to_all in float64: a
# face whose distance is within this of the nearest's is a near tie, either
# right (the two codes round distances a few ulps, 1e-15, apart).
NEAR_TIE_3D = 1e-9
# A float32 3D scene: slaves within this of the radius may be found or not
# (float32 distances of size ~1 round by about 1e-7).
FLOAT32_RADIUS_EDGE = 1e-5
# The signed distance is 1-Lipschitz: gaps a step h apart differ by at most
# h, to float64 rounding of values of size ~1.
LIPSCHITZ_SLACK = 1e-9

# --- Values computed two ways, by the precision they are computed in ---------

# O(1) values exact but for a few float64 roundings (strains, unit gradients).
FLOAT64_EXACT_ATOL = 1e-15
# A float64 formula evaluated in another order or split over devices: a few
# thousand eps, far below any modelling error.
FLOAT64_RTOL = 1e-12
# O(1-10) float64 values (gaps, forces) computed two ways, or summed in another
# order: a few thousand eps of their scale.
FLOAT64_ATOL = 1e-12
# The same float64 program batched (vmap) and not: fused differently, then
# through a gradient's few hundred operations.
FLOAT64_BATCHED_RTOL = 1e-10
# Float64 through hundreds of steps (a material point's scan, a simulation):
# rounding accumulates, relative to the largest value met.
FLOAT64_STEPS_RTOL = 1e-9
# Forces and stresses (N/mm, MPa; up to ~1e3) that cancel to zero or are
# compared after float64 sums of element terms: 1e-12 of their scale.
FORCE_ATOL = 1e-9
# O(1) values computed in float32 (the suite's mode may be x64-off) two ways:
# about 8 ulps of float32.
FLOAT32_ATOL = 1e-6
FLOAT32_RTOL = 1e-6
# Float32 sums of tens of terms (forces over a body, chain lengths) or
# float32 coordinates of size ~10: about 80 ulps.
FLOAT32_SUM_RTOL = 1e-5
FLOAT32_SUM_ATOL = 1e-5
# A slip: the difference of two float32 projections on segments ~10 long,
# moved between steps.
SLIP_ATOL = 2e-5
# A whole simulation rerun with other search sizes: the same contacts, forces
# of ~100 N/mm summed in another order over hundreds of steps.
RERUN_ATOL = 1e-6
# Nodal forces (~1e3 N/mm) of a mesh with a dead element against the mesh
# without it: the same float sums, one zero term fewer and in another order.
MASKED_ELEMENT_ATOL = 1e-4
# Figures worked out by hand to 5 significant digits.
HAND_FIGURE_RTOL = 1e-4
# Means and least-squares lines over thousands of float64 rows of a synthetic
# force history (the steady window, the dips), against their closed forms:
# sums whose rounding grows with the rows, far below any modelling question.
STEADY_FIT_RTOL = 1e-9
# A steady window may take in a ramp's last stretch while its line drifts under 5 %: its
# mean lies within 1 % of the plateau (tests/problems/test_cutting_report.py).
STEADY_MEAN_RTOL = 0.01
# A least-squares slope in log-log of values that do not change: zero but for
# the float64 rounding of their logarithms.
FLAT_SLOPE_ATOL = 1e-9

# Oxley's equilibria (machining.oxley) at its solution, MPa: its roots are
# refined until a residual is below 1e-9 MPa or the step below 1e-12 rad (phi)
# or 1e-10 (C), which the residuals' slopes (~1e4 MPa/rad, ~1e2 MPa) make at
# most ~1e-8 MPa.
OXLEY_RESIDUAL_ATOL = 1e-7

# --- The benchmarks' records ---------------------------------------------------

# A force trace's last point against the run's travel: the point is the mean
# travel over the last of the trace's runs of steps, short of the end by about
# half a run (1/600 of the travel at 300 points), far inside this.
TRACE_END_RTOL = 0.02
# The mean of a trace's points past a travel against the summary's force,
# averaged over its own steady window: two windows over an oscillating force
# (chip segmentation), a few percent apart.
TRACE_MEAN_RTOL = 0.1

# --- Finite differences ------------------------------------------------------

# jax.test_util.check_grads in float64 with a step of FD_STEP: the central
# difference's truncation (step^2 times the third derivative) and rounding
# (eps / step) are both far below these.
FD_STEP = 1e-6
FD_ATOL = 1e-5
FD_RTOL = 1e-4
# A smoother, shorter chain (contact energies with friction): tighter.
FD_SMOOTH_ATOL = 1e-6
FD_SMOOTH_RTOL = 1e-5
# A material point's run: its flow stress is steep, a smaller step.
FD_MATERIAL_STEP = 1e-7
# A hand-made central difference of a whole cutting run in float64 (a step of
# 1e-5 in its parameters): contacts switching within the step, a few 1e-3.
FD_RUN_RTOL = 5e-3
# A hand-made central difference (step 1e-6) of a smooth float64 history.
FD_HISTORY_RTOL = 1e-6
# A gradient against the closed form of the same float64 expression.
CLOSED_FORM_RTOL = 1e-9

# --- Models against analyses (physics, not rounding) --------------------------

# A coarse explicit run against its analytic force: wave noise of a few percent.
EXPLICIT_FORCE_RTOL = 0.03
# Its adiabatic heating against the energy balance, in kelvin.
EXPLICIT_HEAT_ATOL = 3.0
# An element's area after large deformation: the scheme's volume error.
EXPLICIT_AREA_RTOL = 0.01
# Stick-spring oscillation about static friction, averaged over a short run.
STICK_FRICTION_RTOL = 0.05
# The strain-rate term of Johnson-Cook at the end of a run, against its
# logarithm: the rate varies slightly within the last step.
RATE_HARDENING_RTOL = 1e-3
# A slave 2^-10 off a concave corner's face line: its gap differs from the
# corner's by up to that offset.
CORNER_OFFSET_ATOL = 1e-3
# Tangential work that is not dissipated: float32 traction times slip, in
# units of k_t times the slip scale squared.
DISSIPATION_SLACK = 1e-5
# A cylinder pressed into an elastic block against Hertz's line contact (issue
# 43, tests/problems/test_hertz.py), at 12 elements across the contact: the FE a and
# p0 against Hertz's, and the relative L2 error of the nodal pressures over the
# contact, are the targets.
HERTZ_RTOL = 0.03
HERTZ_L2 = 0.05
# The penalty's deepest penetration as a fraction of a: the "small".
HERTZ_PENETRATION = 0.01
# The contact's force on the cylinder against P: Newton stops at a nodal force
# residual of 1e-10 P, and the residual of the cylinder's row is that sum's.
HERTZ_FORCE_RTOL = 1e-8
# jax.grad of the FE peak pressure against Hertz's dp0/dR, dp0/dE: between
# changes of the set of pressed nodes the FE value is linear in E and (by the
# facets) in R, so the slope is a piece's, off by a first-order error in the
# element (7.6 % for E at 12 elements across, 1.4 % at 48; measured).
HERTZ_GRADIENT_RTOL = 0.1
# The same gradient against a central difference of the FE value (step 1e-5 of
# the parameter, inside one piece): the two solves' residuals over the step, a
# few 1e-7 measured.
HERTZ_FD_RTOL = 1e-5
# The midpoint rule over 200,000 intervals of Hertz's ellipse: its error at the ends,
# where the pressure's slope is infinite, is of order the interval to the power 3/2.
MIDPOINT_RULE_RTOL = 1e-6
