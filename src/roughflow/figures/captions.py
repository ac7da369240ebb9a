"""The captions of the study figures, one per study (the figure modules, the command's
``--caption`` and the workflow report all read them here). Importing this module loads
no plotting library, so the workflow can fill the report's captions while it plans."""

from __future__ import annotations

from roughflow.defaults import (
    A_C_STAR_ALT,
    A_C_STAR_BEARING,
    A_C_STAR_PAPER,
    A_C_STAR_THEORY,
    CORRECTION_MIN_POINTS,
    LEAK_MIN_CONTACT_CELLS,
)

_CORRECTED = (
    "a_c* is perimeter-corrected (first-order grid bias of the contact area removed, "
    f"docs/accuracy.md) on grids with >= {CORRECTION_MIN_POINTS:g} points per lambda_s, raw "
    "on coarser ones (raw values there are biased high by about 0.03). "
)

CAPTIONS: dict[str, str] = {
    "channels": (
        "Fluid channels of an isotropic and an anisotropic surface (paper Fig. 1). "
        "(a) Height of the isotropic surface on its 0.5 x 2 cell (gamma = 1), which is also the "
        "anisotropic gamma = 4 unit square after stretching x by 2 and compressing y by 2, in "
        "units of the maximum height. (b) Isotropic and (c) anisotropic elastic contact at "
        "a_c ~ 0.4 (a count of contact cells, as the paper's 39.8 %; at 4 points per "
        "lambda_s about 0.03 above the perimeter-corrected scale of Figs. 2-4): contact in "
        "orange, fluid channels percolating from left to right (along x) in dark blue, "
        "other non-contact in light blue. Both maps are drawn on the same square frame, "
        "so x and y are not to scale for the isotropic cell."
    ),
    "threshold_vs_gamma": (
        _CORRECTED
        + "Critical contact areas a_c* in the stretching (easy, blue) and contraction (hard, "
        "red) directions, x and y for gamma > 1 and y and x below, versus the Peklenik number "
        "gamma (paper Fig. 2): seed means with standard errors (none for a point of one "
        "seed). (a) Elastic contact for the ratios eps_f = lambda_s/lambda_r of the config "
        "(circles: the largest eps_f, then squares, triangles, diamonds); (b) bearing-area "
        "contact, where the config has that model. The paper's H = 0.8 and L/lambda_r = 4 "
        "max(sqrt(gamma), 1/sqrt(gamma)); the "
        "panel titles give the data's model and H. The dotted line marks the paper's "
        f"large-system threshold of elastic contact, {A_C_STAR_PAPER}, and in the bearing "
        f"panel the bearing model's exact isotropic threshold {A_C_STAR_BEARING:g}."
    ),
    "threshold_vs_size": (
        _CORRECTED
        + "Size dependence of a_c* in the stretching (easy, blue) and contraction (hard, red) "
        "directions (x and y for gamma > 1, y and x below), the paper's H = 0.8 (the title "
        "gives the data's model, H and eps_f; paper Fig. 3), versus "
        "eps_t = max(sqrt(gamma), 1/sqrt(gamma)) "
        "lambda_r / L. Circles: the anisotropic gamma with the most system sizes, varying "
        "L/lambda_r; triangles: fixed L/lambda_r with other gamma (labelled, not fitted); "
        "black crosses: "
        "isotropic surfaces. Seed means with standard errors (none for a point of one seed). "
        "Lines: joint fit to the circles' series alone (other gamma follow other "
        "amplitudes: pooled with them, the default run's fits gave chi^2 per degree of "
        "freedom 7-14, against 0.5-2.3 for gamma = 2 alone) "
        "a_c*(eps) = a_c* + A eps^(1/nu) with a fixed nu (2D percolation's 4/3 unless the fit "
        "was run with another, as the legend says) and a shared a_c* (solid) and with nu "
        "free (dashed, where the data determine it: at least three sizes); black dotted: the "
        "fit of the isotropic series; grey band: a_c* of the fixed-nu fit +- its standard "
        "error (bootstrap over seeds; an interval needs Student's t with one degree of "
        "freedom less than the seeds); the text below gives this figure's fitted values, "
        "and says where the law misses the seed means by more than their scatter (the fit's "
        "lack_of_fit). "
        "What larger runs than the default show (docs/accuracy.md section 4, 20-40 seeds, "
        "gamma = 2 up to L/lambda_r = 22.6; not this figure's data): easy and hard "
        "extrapolate to the same a_c* within their errors, "
        "but the anisotropic extrapolation (every gamma != 1 pooled: gamma = 2 at five sizes, "
        "1.5, 3 and 4 at 11.3) lies 0.016 +- 0.006 below the isotropic one (0.394 against "
        "0.410; gamma = 2 alone 0.390, 0.020 +- 0.006 below), and the easy-hard midpoint "
        "at the largest size is already 0.009 +- 0.003 below the isotropic a_c* at the same "
        "eps_t. Perimeter correction, "
        "resolution and correlated seeds do not explain it, and the same analysis finds no "
        "difference for the bearing model (-0.004 +- 0.006); whether it is a genuine gamma "
        "dependence of the elastic threshold or a correction to scaling needs larger cells. "
        "With the default 10 seeds the error of the difference is about 0.012: this figure "
        "cannot decide it; the isotropic crosses sit at the eps_t of the gamma = 2 series so that "
        "the midpoint can be compared at equal eps_t without extrapolating."
    ),
    "threshold_vs_hurst": (
        _CORRECTED
        + "Critical contact areas a_c* in the stretching (easy, blue) and contraction (hard, "
        "red) directions (x and y for gamma > 1, y and x below) versus the Peklenik number "
        "gamma for the Hurst exponents of the config (paper Fig. 4: "
        "H = 0.3 full triangles, H = 0.8 open circles), the paper's elastic contact with "
        "eps_f = 1/16 (the title gives the data's), L/lambda_r = 4 max(sqrt(gamma), "
        "1/sqrt(gamma)); seed means with standard errors (none for a point of one seed). At "
        "gamma = 1 the surface is isotropic: its x and y points, which start the easy and hard "
        "lines, differ by seed scatter alone."
    ),
    "flow_isotropic": (
        "Fluid-flow conductance sigma versus relative contact area a_c (paper Fig. 5), "
        "normalised by sigma_ref, the full Reynolds conductance at a_c -> 0+: full Reynolds "
        "(circles, every seed, mean of x and y; a filled triangle on the bottom edge where "
        "a seed is sealed, sigma = 0 being off the log scale), full Bruggeman "
        "effective-medium theory (solid "
        "lines) and the closed forms of Eq. 16 (dashed lines), one panel per model the config "
        "contains, lettered in the order elastic (non-adhesive), short-range adhesive and "
        "bearing-area contact (the paper's (a), (b), (c)). In the elastic panel a dotted line "
        f"shows the full Bruggeman treatment with a_c* = {A_C_STAR_ALT:g} (the study's "
        "a_c_star_alt); the other lines use the study's "
        "a_c_star (default "
        + ", ".join(f"{v:g} {k}" for k, v in A_C_STAR_THEORY.items())
        + "; the paper's 0.4 for elastic and adhesive contact). "
        "Elastic a_c is perimeter-corrected (first-order grid bias of the contact area "
        "removed, docs/accuracy.md); bearing and adhesive a_c are cell counts. "
        "A study that sweeps gamma, H, L/lambda_r or eps_f draws a row of panels per "
        "combination, titled with its values; the rows share each column's axes. "
        "Where this figure departs from the paper: at 2 points per lambda_s "
        "(config/config.yaml) the elastic fluid stops percolating early on the corrected "
        "scale (threshold searches at 2 points give a corrected a_c* of 0.393, against "
        "0.413 at 4 points; L/lambda_r = 8, seeds 0-4), so full Reynolds seals from a_c "
        "about 0.39 and is low just before; "
        "roughflow's adhesive model (calibrated on "
        "the paper's contact areas, docs/contact.md) still percolates at cell counts of "
        "0.44-0.48 (search.threshold(model='adhesive'), 512^2, seeds 0-2), so with a_c* = 0.4 "
        "full Bruggeman falls 3.2-3.8 times (the closed form 4-5 times) below full Reynolds "
        "at a_c 0.39, where the paper finds full Bruggeman close (a_c_star "
        "{adhesive: 0.46} in the config follows the model); and at 2 points per lambda_s "
        "(config/config.yaml) the bearing model's full Bruggeman lies 46-67 % above full "
        "Reynolds at a_c 0.2-0.3, within about 20 % at the 8 points of config/paper.yaml "
        "(docs/theory.md, section 'The flow figures against the paper')."
    ),
    "flow_anisotropic": (
        "Fluid conductance in the stretching (easy, x, blue) and contraction (y, red) "
        "directions for an anisotropic surface (paper Fig. 6: elastic, Fig. 7: bearing-area "
        "contact), normalised by sigma_ref (mean full Reynolds conductance at a_c -> 0+). "
        "Symbols: full Reynolds (every seed; a filled triangle on the bottom edge where a seed "
        "is sealed along that direction, sigma = 0 being off the log scale); solid lines: "
        "the corrected anisotropic Bruggeman "
        "theory (Eq. 9); dashed: Persson's form (Eq. 7), which coincides with Eq. 9 where "
        "a_c* = 0.5 (the bearing model's default), hidden under it there; grey dotted: "
        "isotropic Bruggeman. "
        "Right panel: the ratio chi = sigma_x / sigma_y of full Reynolds (symbols) and the "
        "corrected theory (lines) with gamma^2 (grey; gamma of the heights), the value both "
        "Bruggeman forms approach at a_c*, a filled triangle on "
        "the top edge where a seed is sealed along y only (chi infinite); the paper reports "
        "chi ~ 8 for the elastic contact at gamma = 2 versus 4 from the theory (at no stated "
        "a_c: roughflow gives about 8 at a_c 0.2-0.25 and more beyond, where sigma_y "
        "approaches its own threshold first). "
        "Elastic a_c is perimeter-corrected (first-order grid bias of the contact area "
        "removed, docs/accuracy.md); bearing and adhesive a_c are cell counts. "
        "A study that sweeps gamma, H, L/lambda_r or eps_f draws a row of panels per "
        "combination, titled with its values; the rows share each column's axes. "
        "At 2 points "
        "per lambda_s (config/config.yaml) the elastic fluid stops percolating early on the "
        "corrected scale (corrected a_c* 0.393 against 0.413 at 4 points, isotropic), so "
        "sigma_y seals from a_c about 0.36 and chi rises early; the bearing model's "
        "Bruggeman lines lie 1.9-2.9 times above full Reynolds along y at a_c 0.2-0.39 and "
        "its chi reaches 6.5 against 3.3; at the 8 points of config/paper.yaml chi is "
        "3.4-4.1 and Bruggeman within 10 % up to a_c 0.2-0.25, the paper's close agreement "
        "(docs/theory.md, section 'The flow figures against the paper')."
    ),
    "measured": (
        "Leak rate Q of a seal versus the nominal contact pressure for each measured scan "
        "(roughflow import + roughflow leak; docs/measured.md), one colour and marker per "
        "scan: flow along x (solid) and y "
        "(dashed) for the seal width, length, fluid pressure drop and viscosity of the config. "
        "Q = 0 once the fluid no longer percolates; the shaded bands in the scan's colour mark "
        "its sealing pressure along x (plain) and y (hatched), between the highest pressure "
        "found leaking and the lowest found sealed (a line where it is sealed). Right: the "
        "relative contact area a_c. Hollow markers, off the lines: rows whose analysed "
        "window holds no contact cell or contact on fewer than "
        f"{LEAK_MIN_CONTACT_CELLS} cells (the leak table's '*' and '~'), not resolved: an "
        "empty window is held open from outside, a few cells under-resolve a_c, the gap and "
        "Q; the figure's caption file (.md) counts them and states each scan's sealing "
        "pressures. "
        "Each scan's non-periodic treatment is "
        "in the dataset's per-scan 'boundary' variable (the title names it where all scans "
        "share it, the legend per scan where they differ); the seal, fluid and scan provenance "
        "are per-scan variables too. Scans with different pressure grids are each drawn at "
        "their own pressures."
    ),
}
