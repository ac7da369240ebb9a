"""Default values and fixed names shared by the library, the command line and the workflow.

Each value is written here once; the argparse options, the job dataclasses and the sweep
expansion read it, and ``tests/test_defaults.py`` checks the workflow schema against it.
This module imports nothing, so the command line can build its help without the numerical
stack. Units: E* = 1, rms gradient 1, cell side L = 1, viscosity eta = 1.
"""

from __future__ import annotations

#: Names of the two directions, axis 0 and axis 1 of every array (gamma > 1 stretches x).
AXIS_NAMES = ("x", "y")
#: Contact models: hard-wall elastic, elastic with short-range adhesion, bearing area.
MODELS = ("elastic", "adhesive", "bearing")
#: The model a solve, a search, a job or a theory line takes when none is named.
DEFAULT_MODEL = "elastic"

# --- surfaces (docs/physics.md Sect. 2) --------------------------------------------------
#: Peklenik number (> 1 stretches along x).
GAMMA = 1.0
#: Hurst exponent H.
HURST = 0.8
#: eps_f = lambda_s / lambda_r (the paper's default).
EPS_F = 1 / 16
#: Grid points per shortest wavelength lambda_s of a generated surface.
POINTS_PER_LAMBDA_S = 8.0
#: lx / ly of a unit-area cell.
ASPECT = 1.0
#: Roll-off of the height spectrum: smooth (1 + (q/q_r)^2)^-(1+H), as in the paper, or a
#: plateau below q_r.
ROLLOFF_FORMS = ("smooth", "plateau")
ROLLOFF = "smooth"
#: Slack with which lengths given as ratios (L / lambda_r, points per lambda_s) round to whole
#: grid points and mode numbers: a product such as 16 * 4 * 0.9999999999 is 64 points.
GRID_ROUNDING_SLACK = 1e-9
#: L / lambda_r in the easy direction when none is given: the paper's
#: L / lambda_r = PAPER_SIZE_FACTOR max(sqrt(gamma), 1/sqrt(gamma)).
PAPER_SIZE_FACTOR = 4.0
#: Target of each numerical error in a_c* (docs/accuracy.md): a third of the standard error
#: of the paper's 10-seed means, about 0.01.
A_C_STAR_ERROR_BUDGET = 0.01 / 3
#: Seeds of the accuracy study (``roughflow accuracy``, the workflow's ``accuracy`` target).
ACCURACY_SEEDS = (0, 1, 2, 3, 4, 5)
#: Fewest grid points per lambda_s at which a_c is perimeter-corrected: the constant is
#: calibrated on 4 to 16 points per lambda_s (docs/accuracy.md).
CORRECTION_MIN_POINTS = 4.0

# --- contact (docs/contact.md) -------------------------------------------------------------
#: Contact methods: mass-weighted GFMD (the default; hard wall: projected CG in the mass
#: metric, adhesion: FIRE) and Polonsky-Keer CG on the pressure.
CONTACT_METHODS = ("gfmd", "cg")
#: Where the elastic gfmd solves run: "cpu" (numpy, pyFFTW, numba) or "cupy" (a CUDA GPU,
#: roughflow.gpu).
BACKENDS = ("cpu", "cupy")
DEFAULT_BACKEND = "cpu"
#: Residual of a single contact solve: largest gap error over the rms height.
CONTACT_TOL = 1e-6
#: Solver steps between two DEBUG progress lines of a contact solve (roughflow -vv).
SOLVER_LOG_EVERY = 20
#: Iterations between two exact residual checks of FIRE and the adhesive CG (each check
#: costs an inverse transform; the hard wall's CG decides from its free estimate).
CONTACT_CHECK_EVERY = 5
#: Iteration cap of one contact solve per method, where the caller gives none.
CONTACT_MAX_ITER = {"cg": 20000, "gfmd": 50000}
#: Loosest contact tolerance accepted: a gap error of 1 % of the rms height (a looser one
#: returns the starting state after zero iterations as "converged").
CONTACT_TOL_MAX = 1e-2
#: Tightest contact tolerance accepted: below it solves stall on round-off and run to the
#: iteration cap (tol 1e-16 on a 128 x 96 scan: 50000 steps, exit 3). Measured on generated
#: surfaces (H 0.8, L/lambda_r 4, eps_f 1/16, 128^2 - 2048^2) and two 128-point scans with
#: elastic gfmd and cg and both adhesive walls: from a_c about 0.003 up every solver reaches
#: 1e-13; at small loads gfmd's load balance, held relative to the load, stalls it at
#: 1.5e-12 - 3.7e-12 (1e-6 - 1e-4 E* gbar, a_c <= 5e-4; 128^2, 512^2, the scans) and at
#: 1.9e-11 (1024^2, 1e-5 E* gbar); every solve measured, 2048^2 at 1e-5 and 1e-4 E* gbar
#: included, reaches 1e-10. A gap error of 1e-10 rms heights is far below anything a_c or
#: the gap resolve (the default 1e-6 holds them to about 1e-7, docs/contact.md).
CONTACT_TOL_MIN = 1e-10
#: The adhesive model (docs/contact.md "Adhesion"): a hard wall ("hard") or a harmonic
#: repulsion ("harmonic") under the cosine attraction.
ADHESION_REPULSIONS = ("hard", "harmonic")
#: The default repulsion: the hard wall, which reproduces the paper's adhesive contact areas
#: (at zero load, at 1/8 and 1/4 of the non-adhesive loads of 10 % and 40 %) and comes close
#: to its mean gap "about 10 % below" the non-adhesive one (12 % and 17 % below with contact
#: cells closed, 11 % and 10 % counting their physical gap); the harmonic wall reproduces the
#: areas but not the gap (32 % and 48 % below).
ADHESION_REPULSION = "hard"
#: A cell is in adhesive contact where its gap is below this fraction of the range rho, where
#: the attraction's tension peaks (hard wall; the harmonic wall counts overlap, g < 0).
ADHESION_CONTACT_WITHIN = {"hard": 0.5, "harmonic": 0.0}
#: The paper's adhesive case, calibrated for each repulsion on the surface of its Fig. 5:
#: surface energy gamma_s / v_ela^full ...
ADHESION_SURFACE_ENERGY_RATIO = 0.1
#: ... and interaction range rho / lambda_s.
ADHESION_RANGE_OVER_LAMBDA_S = {"hard": 0.8, "harmonic": 0.42}

# --- percolation thresholds (docs/percolation.md) ----------------------------------------
#: The paper's large-system critical contact area of elastic contacts, 0.415 +- 0.01: the
#: reference line of the threshold figures and the first target of a threshold search.
A_C_STAR_PAPER = 0.415
#: The bearing model's threshold of isotropic surfaces, exactly 1/2 (heights symmetric about
#: the mean: the fluid of one surface is the contact of its mirror image; paper Sect. 3.2):
#: the reference line of its threshold panels.
A_C_STAR_BEARING = 0.5
#: Largest allowed a_hi - a_lo of a threshold bracket.
THRESHOLD_TOL = 2e-3
#: Widest bracket accepted (a_c* itself varies by about 0.1 between systems).
THRESHOLD_TOL_MAX = 0.1
#: Contact-solve tolerance inside a threshold search (docs/accuracy.md: a_c* moves by less
#: than 6e-5 against a 1e-7 solve).
THRESHOLD_CONTACT_TOL = 1e-4
#: The largest load (E* gbar) a search for a contact area tries: elastic contact is nearly
#: full at 2 (the elastic law's erf(2 sqrt(pi)) > 0.999).
MAX_SEARCH_LOAD = 4.0
#: Pressures (E* gbar) a threshold search may try.
THRESHOLD_PRESSURE_RANGE = (1e-4, MAX_SEARCH_LOAD)
#: The largest pressure (E*, either sign) a contact solve, a leak curve or a threshold
#: search accepts: a hundred times the contact modulus is no linear-elastic contact (every
#: gap of a surface with gbar up to 25 is closed from 4 E* gbar on), but a pressure in
#: pascals passed where the library takes units of E*. Not a bound in E* gbar: one study's
#: pressures serve smooth and rough scans alike, and on a smooth one a_c = 1 and Q = 0 is
#: the answer, not an error.
CONTACT_PRESSURE_MAX = 100.0
#: An elastic load whose contact the small-load law (a_c = 2 p / (E* gbar)) puts at fewer
#: than this many grid cells is refused: below about one cell the contact is one cell
#: whatever the load (512^2: one cell from 1e-7 to 1e-13 E* gbar), and gfmd's load balance,
#: relative to the load, reaches the round-off of the force, so the solve ran its 50,000
#: iterations and failed (512^2 at 1e-10; 64^2 at 1e-11). At this floor it converged on
#: every grid tried (512^2 - 2048^2: 44-206 iterations).
CONTACT_MIN_CELLS = 1e-3
#: Cap on the contact solves of one threshold search.
THRESHOLD_MAX_SOLVES = 40
#: Threshold search strategies: aimed refinement (default) and plain bisection (reference).
THRESHOLD_STRATEGIES = ("predict", "bisect")
THRESHOLD_STRATEGY = "predict"

# --- theory lines of the flow studies (paper Fig. 5-7) ------------------------------------
#: a_c* of the Bruggeman and closed-form lines per model: the paper draws its Fig. 5 theory
#: lines with 0.4 for elastic and adhesive contacts; the bearing model's exact threshold is 1/2.
A_C_STAR_THEORY = {"elastic": 0.4, "adhesive": 0.4, "bearing": A_C_STAR_BEARING}
#: The second isotropic Bruggeman line of Fig. 5a.
A_C_STAR_ALT = 0.5
#: Correction factor gamma_P of Persson theory's stored elastic energy (Yang & Persson 2008;
#: docs/theory.md).
PERSSON_ENERGY_FACTOR = 0.42
#: Pressures (E* gbar) of a Persson prediction where none are given (``roughflow theory``).
PERSSON_PRESSURES = (0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.15, 0.2, 0.25)
#: Largest |a_c - target| of a pressure-ladder step (contact area, absolute).
LADDER_AREA_TOL = 5e-3
#: The loosest such tolerance a ladder accepts: its steps are 0.03-0.05 apart in a_c.
LADDER_AREA_TOL_MAX = 0.1

# --- Reynolds flow (docs/flow.md) ----------------------------------------------------------
#: Relative residual of the linear flow solve.
FLOW_TOL = 1e-8
#: Loosest flow tolerance accepted: the solve is refined until the inlet and outlet fluxes
#: agree to ``tol``, so a looser one gives no usable flux balance (``tol`` 1e6 gave sigma
#: 1e4 times too large after zero iterations).
FLOW_TOL_MAX = 1e-2
#: Largest relative error of sigma that a flow solve returns: the upper bound on the
#: dissipation's error that every solve reports (docs/flow.md "Error bound", "Flux check");
#: a solve whose bound exceeds it raises, whatever its flux balance. On
#: near-threshold states kept by the stress walks (1024^2 - 2048 x 4096) a direct solve's
#: r^T A^-1 r / Q was 2e-13 - 2.3e-5, at round-off (a refinement step moves it by its own
#: size); 1e-3 in sigma is 1e-3 in ln sigma, at least 250 times below its seed-to-seed
#: spread (0.27 - 0.98 at a_c 0.2 - 0.35, docs/accuracy.md). So a solve raises only where
#: float64 leaves sigma unproven by far more than the paper's numbers can tell (docs/flow.md).
FLOW_SIGMA_RTOL = 1e-3
#: Proven relative error of sigma at which the ladder's and ``leak``'s iterative flow solves
#: stop (``flow.solve(sigma_tol=)``), whatever their residual and flux balance: the ladder's
#: contact tolerance (1e-6) alone moves sigma by up to 6e-7 (docs/accuracy.md), and the
#: seed-to-seed sd of ln sigma is 0.27 - 0.98. RS-CG certifies it after 6-9 iterations where
#: the residual and flux criteria take 9-16 (docs/flow.md "Stopping at sigma's accuracy").
FLOW_SIGMA_TOL = 1e-6
#: A cell whose local conductivity u^3 / (12 eta) is at most this fraction of the largest
#: carries no flow: float64 cannot resolve it beside the largest (a gap below 4.6e-6 of the
#: largest gap). Contact solves leave such cells at contact edges (gaps of 2e-8 - 5e-6 of
#: the largest, within the contact solver's tolerance). Left open, they stalled RS-CG
#: (residual 3e-7 - 3e-6 after 500 iterations) on a 1024^2 ladder state that the direct
#: solve takes in 2.4 s; closed, RS converges in 16 iterations and sigma moves by 4e-16
#: (docs/flow.md "Unresolved gaps"). Cells above it are solved, but not always resolved: many
#: thin layers in series lose sigma from 1e-10 - 1e-13 of the rest, and the solve raises there.
FLOW_CLOSED_BELOW = 1e-16
#: Where the open cells left out by that floor may carry more than this share of sigma (a
#: rigorous bound from the solved pressures, flow.bound.dropped_flow), the solve is repeated
#: with them: the floor's scale is the largest face, so a deep pocket raised it over whole
#: flowing channels (sigma 2.7e-4 low, or 0 for two open channels). On contact gaps the
#: bound was at most 2e-15 (256^2 and 512^2, a_c 0.11 - 0.45, 58 solves), so they never are.
DROPPED_FLOW_RESOLVE = 1e-9
#: Where a solve cannot be certified (or the floor above closes every path), regions whose
#: faces conduct at least this many times more inside than any face out of them (deep
#: dead-end pockets, open stripes between closed ones) are solved as one unknown each, or at
#: a reservoir's pressure where they reach it (flow.lump), with the floor scaled by the faces
#: outside them: float64 cannot resolve their inner pressure differences, while the lumped
#: field stays admissible and its error, about 1 / ratio of the region's share of the flow,
#: is certified like any other. The ratios are tried in turn until a solve is certified: a
#: pocket of graded depths (gaps 100, 1e4, 1e6 beside a channel of 1) has no single step of
#: 1e8 in u^3 (docs/flow.md "Unresolved gaps").
FLOW_LUMP_RATIOS = (1e8, 1e6, 1e4)
#: Linear solvers of the flow: auto (direct for small systems and thin flowing clusters,
#: else rs), Ruge-Stueben AMG + CG, smoothed aggregation + CG, sparse direct, plain CG.
FLOW_METHODS = ("auto", "rs", "sa", "direct", "cg")
FLOW_METHOD = "auto"

# --- measured scans and leak questions (docs/measured.md) ---------------------------------
#: Detrending of an imported scan: none, plane (mean and tilt) or curvature (plane plus a
#: quadratic), fitted to the defined points; or line levelling for scans recorded line by
#: line (AFM): each line along x (lines-x) or along y (lines-y) loses its own mean and tilt.
DETREND_MODES = ("none", "plane", "curvature", "lines-x", "lines-y")
SCAN_DETREND = "plane"
#: The package that reads every scan format, and the extra of roughflow that installs it.
SCAN_READER, SCAN_READER_EXTRA = "SurfaceTopography", "topography"
#: Missing points of a scan: refuse the scan (none), Laplace interpolation from the defined
#: neighbours (harmonic), or the lowest defined height (min: open, so conservative for leaks).
FILL_METHODS = ("none", "harmonic", "min")
SCAN_FILL = "none"
#: ``crop`` value that keeps the largest grid window of a scan without a missing point.
SCAN_CROP_DEFINED = "defined"
#: A fill of more than this fraction of a scan's points is reported (a warning naming the
#: largest window without missing points): a filled region is smooth (harmonic) or a flat
#: basin (min), so where it is large it, not the measured surface, shapes the contact.
SCAN_FILL_WARN_FRACTION = 0.05
#: Pixels whose sides differ by more than this fraction draw a warning at import: rectangular
#: pixels exist (fewer lines than points per line), but more often they mean a size given
#: for swapped axes, e.g. an [x, y] array written with np.savetxt, whose rows SurfaceTopography
#: reads as lines along x.
SCAN_PIXEL_ASPECT_WARN = 0.01
#: A scan whose heights vary by less than this fraction of their largest magnitude after
#: detrending is flat (refused): detrending a constant or a plane leaves round-off of
#: about 1e-16 of the heights, a measured surface varies by far more than 1e-9 of them.
SCAN_FLAT_RELATIVE = 1e-9
#: An imported scan's rms gradient outside this range draws a warning naming the units:
#: measured surfaces lie between about 1e-3 (polished, optical profiler) and 1-2 (AFM at
#: nm pixels); heights in nm read as um give 1000 times the slope (884 instead of 0.88,
#: measured), in um read as nm a thousandth. The small-slope contact model needs gbar < 1
#: anyway; the range only catches unit mix-ups.
SCAN_GRADIENT_WARN = (1e-5, 10.0)
#: A scan that seals only above this contact area draws a note in the leak table: random
#: surfaces seal at a_c* of about 0.4 (0.3-0.7 anisotropic, the paper's Fig. 2), and one
#: AFM scan sealed at 0.99 along x because one scan line lay 4 nm below its neighbours
#: (0.50 with its lines levelled).
SEALING_AREA_NOTE = 0.8
#: A leak-curve row whose analysed window holds contact, but fewer cells of it than this, is
#: flagged as under-resolved (roughflow.leak.few_cell_pressures; no contact at all has its
#: own flag). a_c converges to first order: the grid over-counts contact by c = 0.105 cell
#: areas per contact/non-contact face (accuracy.PERIMETER_C, docs/accuracy.md), and n cells
#: have at least about 4 sqrt(n) faces (one compact spot), so a_c is off by 0.42 / sqrt(n)
#: of itself or more: about 42 % for one cell, 10 % at 16. 16 cells are also a 4 x 4 square,
#: one shortest wavelength at the fewest points per lambda_s that a_c is corrected at
#: (CORRECTION_MIN_POINTS). The gap and leak rate such spots hold open are no better
#: resolved than the spots themselves.
LEAK_MIN_CONTACT_CELLS = 16
#: A nominal pressure (E*) from which a leak-curve row, a sealing pressure or a contact
#: solve is flagged (roughflow.leak.large_strain): at p ~ E* the elastic strains are of
#: order one, outside the linear-elastic half-space (small strains, small slopes) that every
#: solver here assumes. Flagged, not refused: the library takes up to CONTACT_PRESSURE_MAX
#: on purpose (full contact is an answer). In E*, not E* gbar: the strain under the
#: nominal load is p / E* whatever the rigid rough face's slopes. Seals run far below it
#: (an elastomer at about 0.1 E*), so nothing lower is flagged.
LARGE_STRAIN_PRESSURE = 1.0
#: How a non-periodic scan meets the periodic solvers (roughflow.boundary): mirror-tiled,
#: padded by a flat region far below it, an interior window of the scan solved as periodic,
#: or the scan taken as periodic.
BOUNDARY_METHODS = ("mirror", "pad", "window", "periodic")
#: The default for non-periodic scans: the smallest effect on a_c, a_c* and sigma measured on
#: windows cut from periodic surfaces (benchmarks/nonperiodic.py, docs/measured.md).
BOUNDARY = "window"
#: The "window" method drops this fraction of the scan at each side.
WINDOW_MARGIN = 0.125

# --- the sweep workflow (config/config.yaml) ----------------------------------------------
#: Studies that compute thresholds only (paper Fig. 2-4).
THRESHOLD_STUDIES = ("threshold_vs_gamma", "threshold_vs_size", "threshold_vs_hurst")
#: Studies with a pressure ladder and flow solves (paper Fig. 5-7).
FLOW_STUDIES = ("flow_isotropic", "flow_anisotropic")
#: Leak curves of measured scans in physical units (docs/measured.md); not a paper figure.
MEASURED_STUDY = "measured"
#: Every study, one figure each (channels: paper Fig. 1).
STUDIES = ("channels", *THRESHOLD_STUDIES, *FLOW_STUDIES, MEASURED_STUDY)
#: Parameters of which a threshold study's figure (and fit) shows one value; and the studies
#: whose figure shows one system size per point. The figures refuse other datasets, and the
#: planner (roughflow.scenes.expand) other configs, before any job. The flow studies draw a
#: row of panels per setting instead (roughflow.scenes.expand.flow_rows).
STUDY_ONE_VALUE = {"threshold_vs_gamma": ("hurst",),
                   "threshold_vs_size": ("model", "hurst", "eps_f"),
                   "threshold_vs_hurst": ("model", "eps_f")}
STUDY_ONE_SIZE = ("threshold_vs_gamma", "threshold_vs_hurst")
#: Values a study's figure requires (the isotropic flow figure averages x and y), checked
#: by the planner and the figure alike; the study that draws other values.
STUDY_FIXED = {"flow_isotropic": ({"gamma": 1.0}, "flow_anisotropic")}
#: L / lambda_r of a flow study when none is given (the paper's Fig. 5).
FLOW_L_OVER_LAMBDA_R = 16.0
#: The channels scene (paper Fig. 1): H = 0.8, gamma = 4, lambda_r = 0.25, lambda_s = 0.025
#: on unit-area cells, pressed to a_c = 0.4.
CHANNELS = {"gamma": 4.0, "hurst": 0.8, "l_over_lambda_r": 4.0, "eps_f": 0.1,
            "area_fraction": 0.4, "model": "elastic", "seed": 1, "points_per_lambda_s": 8.0}
#: Largest |a_c - target| of the channels scene's contact.
CHANNELS_AREA_TOL = 2e-3

# --- finite-size scaling (paper Fig. 3) ----------------------------------------------------
#: Correlation-length exponent of 2D percolation.
NU_PERCOLATION = 4 / 3
#: Range a free nu is searched in, and that a fixed one must lie in (errors.check_nu).
NU_BOUNDS = (0.3, 6.0)
#: Bootstrap resamples over seeds for the fit errors.
FIT_BOOTSTRAP = 200
#: The most resamples a fit takes: at n resamples the error estimate itself scatters by about
#: 1/sqrt(2 n) relative (0.7 % at 1e4, far below the seed-sampling error of a few seeds'
#: bootstrap); 1e4 took about 5 minutes for the default run's threshold_vs_size (30 ms per
#: resample), so a mistyped 1e9 would run for years.
FIT_BOOTSTRAP_MAX = 10_000
#: Below this many seeds a fit's errors come with a warning: with n seeds the estimate's
#: scatter follows Student's t with n - 1 degrees of freedom, and even the corrected
#: bootstrap error covers the truth at 1 error in 47 % (2 seeds) - 65 % (4 seeds) of
#: synthetic studies, 68 % from about 10 (fits.bootstrap_fit; docs/accuracy.md).
FIT_MIN_SEEDS = 5
#: A fit whose chi^2 per degree of freedom (residuals of the seed means over their standard
#: errors) exceeds the quantile at this probability of the F distribution (the degrees of
#: freedom, n_seeds - 1: the standard errors are estimated from the seeds) is flagged
#: ``lack_of_fit``: its bootstrap errors, which measure the seeds' scatter only, do not
#: cover a law that misses the data. On data that follow the law it flagged 0-1.3 % of
#: synthetic studies at 3-20 seeds, where chi^2's own quantile flagged 57 % at 3 seeds,
#: 36 % at 4 and 8 % at 8 (fits.bootstrap_fit; 300 studies each, 12 points).
FIT_LACK_OF_FIT_QUANTILE = 0.99

#: The kinds of job file (roughflow.datasets.kinds) that ``roughflow aggregate`` combines.
JOB_KINDS = ("threshold_job", "ladder_job", "leak_job")
