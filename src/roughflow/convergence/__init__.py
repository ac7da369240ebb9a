"""The accuracy budget: numerical error of a_c* and sigma against wall time.

Three steps, each a function and a ``roughflow accuracy`` subcommand; the first two append
JSON-lines records to a record log (:mod:`~roughflow.convergence.records`), written whole as
a netCDF dataset when a run completes (:mod:`~roughflow.convergence.dataset`), and those
datasets are the input of the third (docs/accuracy.md):

- :func:`~roughflow.convergence.measure.measure_resolution`: per seed, one surface generated
  at the finest resolution and sampled down to every coarser one (the spectrum is
  band-limited below q_s, so ``h[::k, ::k]`` is the same continuum surface on a coarser
  grid); a_c* along x and y, the contact-line faces at the threshold, and sigma_x at
  a_c = 0.2 and 0.35 (or, without sigma, the contact law's fixed loads that fit the
  perimeter constant of :func:`roughflow.accuracy.perimeter_corrected_area`).
- :func:`~roughflow.convergence.measure.measure_tolerances`: at one resolution, a_c*, a_c,
  mean gap and sigma against the contact solver tolerance, and a_c* against the bisection
  tolerance.
- :func:`~roughflow.convergence.report.write_report` and
  :func:`~roughflow.convergence.anisotropic.write_anisotropic_report`: markdown tables, CSV
  and error-versus-time plots.

The options of the first two are :mod:`roughflow.convergence.options` (the command line's
defaults; importing it loads no numerical library). This package imports nothing at import
time, so that ``roughflow --help`` stays light.
"""
