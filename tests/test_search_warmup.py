"""`roughflow.search.warm_up` leaves nothing for a later search to compile.

Benchmarks call it so that their first timed search is not a numba compile (on a fresh
machine the first of ten threshold pairs took 7.3-7.9 s instead of about 2.5 s at 1024^2). The
check runs in a fresh interpreter: in this one, earlier tests have compiled everything.
"""

import subprocess
import sys
import textwrap

CHECK = textwrap.dedent("""
    import importlib, pkgutil
    from numba.core.registry import CPUDispatcher
    import roughflow
    from roughflow.search import threshold, warm_up
    from roughflow.surface import SurfaceSpec, generate

    def compiled():
        out = {}
        for info in pkgutil.walk_packages(roughflow.__path__, "roughflow."):
            if info.name.endswith("__main__"):
                continue
            mod = importlib.import_module(info.name)
            for name, obj in vars(mod).items():
                if isinstance(obj, CPUDispatcher) and obj.__module__ == mod.__name__:
                    out[f"{mod.__name__}.{name}"] = len(obj.signatures)
        return out

    compiled()  # import every module first: importing must not count as a search's compile
    warm_up()
    before = compiled()
    # another shape and gamma than the warm-up surface, both axes, two threads, and the
    # bearing model: the calls a scene or a benchmark makes
    s = generate(SurfaceSpec.from_sweep(gamma=4, points_per_lambda_s=2, seed=3))
    threshold(s, tol=4e-3, threads=2)
    threshold(s, 0, model="bearing")
    after = compiled()
    new = sorted(k for k in after if after[k] != before[k])
    assert len(before) > 20, before  # the finder sees roughflow's kernels (29 today)
    print("NEW", new)
""")


def test_warm_up_compiles_every_kernel_a_search_runs():
    out = subprocess.run([sys.executable, "-c", CHECK], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr
    assert "NEW []" in out.stdout, out.stdout
