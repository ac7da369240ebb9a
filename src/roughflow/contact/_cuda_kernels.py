"""Fused CUDA loops of the hard-wall CG (``gfmd._hard_wall`` with ``backend="cupy"``): the
GPU forms of the numba kernels ``_kernels.cg_*``, ``max_abs`` and ``max_abs_free``, with
the same arguments and results (one pass over memory each, instead of the 5-15 passes of
their array-module twins).

Reductions are deterministic: each block reduces its share of a grid-stride loop in shared
memory and writes one partial per result; the partials (at most ``MAX_BLOCKS`` per result)
are copied to the host and reduced there in a fixed order. The grid depends only on the
array size, so a solve repeats bit for bit on one GPU model.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from roughflow import gpu

from . import _kernels

#: Threads per block (the CUDA source's BLOCK, its shared-memory reduction's width).
BLOCK = 256
#: Blocks of a launch at most: about one wave on an H100 or H200 (132 multiprocessors, 8
#: resident blocks of 256 threads each).
MAX_BLOCKS = 1024

_SOURCE = f"#define BLOCK {BLOCK}\n" + r"""
// max that keeps a nan (as numpy's max and the numba kernels: a residual must not skip one)
__device__ __forceinline__ double maxnan(double a, double b) { return (b > a || b != b) ? b : a; }
// max(x, 0) that keeps a nan, as Python's max(x, 0.0) in the numba kernels
__device__ __forceinline__ double pos(double x) { return x < 0.0 ? 0.0 : x; }
__device__ __forceinline__ double rfft_weight(long long i, int nh, int ny) {
    int j = (int)(i % nh);
    return (j == 0 || 2 * j == ny) ? 1.0 : 2.0;
}

// op 0: sum, 1: max (nan kept), 2: min; the block's result in thread 0
__device__ double block_reduce(double v, double* sh, int op) {
    int t = threadIdx.x;
    sh[t] = v;
    __syncthreads();
    for (int s = BLOCK / 2; s > 0; s >>= 1) {
        if (t < s) {
            double a = sh[t], b = sh[t + s];
            sh[t] = op == 0 ? a + b : (op == 1 ? maxnan(a, b) : fmin(a, b));
        }
        __syncthreads();
    }
    double r = sh[0];
    __syncthreads();
    return r;
}

#define LOOP(n) for (long long i = blockIdx.x * (long long)BLOCK + threadIdx.x; i < (n); \
                     i += (long long)gridDim.x * BLOCK)
#define PUT(k, op, v) { double r_ = block_reduce((v), sh, (op)); \
                        if (threadIdx.x == 0) part[(k) * gridDim.x + blockIdx.x] = r_; }

extern "C" __global__ void cg_update(double* g, double* f, const double* d, const float* fks,
        double t, double alpha, double eps, float* r, bool* active, long long n,
        double* part) {
    __shared__ double sh[BLOCK];
    double total = 0.0;
    LOOP(n) {
        double gi = g[i], fi = f[i];
        if (t != 0.0) {
            double gt = pos(gi + alpha * d[i]);
            gi = pos(gi + t * (gt - gi));
            fi = fi + t * (double)fks[i];
            g[i] = gi;
            f[i] = fi;
        }
        bool on = (gi <= eps) && (fi < 0.0);
        active[i] = on;
        double ri = on ? 0.0 : fi;
        r[i] = (float)ri;
        total += ri;
    }
    PUT(0, 0, total);
}

extern "C" __global__ void cg_precondition(const float2* rt, const double* pre, float2* rt_old,
        float2* out, long long n, int nh, int ny, double* part) {
    __shared__ double sh[BLOCK];
    double rz = 0.0, roz = 0.0;
    LOOP(n) {
        double w = rfft_weight(i, nh, ny);
        float2 c = rt[i];
        float2 co = rt_old[i];
        double p = pre[i];
        double cr = c.x, ci = c.y;
        out[i] = make_float2((float)(cr * p), (float)(ci * p));
        rz += w * p * (cr * cr + ci * ci);
        roz += w * p * ((double)co.x * cr + (double)co.y * ci);
        rt_old[i] = c;
    }
    PUT(0, 0, rz);
    PUT(1, 0, roz);
}

extern "C" __global__ void cg_direction(const float* z, double* d, const double* g,
        const double* f, double beta, double alpha, float* s_in, const bool* active,
        long long n, double* part) {
    __shared__ double sh[BLOCK];
    double nclip = 0.0, fs = 0.0, zmax = 0.0, smax = 0.0;
    LOOP(n) {
        bool on = active[i];
        double zi = on ? 0.0 : (double)z[i];
        zmax = maxnan(zmax, fabs(zi));
        double di = on ? 0.0 : zi + beta * d[i];
        d[i] = di;
        double gi = g[i];
        double gt = gi + alpha * di;
        nclip += gt < 0.0 ? 1.0 : 0.0;
        double si = pos(gt) - gi;
        s_in[i] = (float)si;
        smax = maxnan(smax, fabs(si));
        fs += f[i] * si;
    }
    PUT(0, 0, nclip);
    PUT(1, 0, fs);
    PUT(2, 1, zmax);
    PUT(3, 1, smax);
}

extern "C" __global__ void cg_feasible(const double* g, const double* d, double alpha,
        long long n, double* part) {
    __shared__ double sh[BLOCK];
    double tf = __longlong_as_double(0x7ff0000000000000LL);  // +inf
    LOOP(n) {
        double gi = g[i];
        double si = pos(gi + alpha * d[i]) - gi;
        if (si < 0.0) tf = fmin(tf, gi / -si);
    }
    PUT(0, 2, tf);
}

extern "C" __global__ void cg_stiffness(const float2* st, const float* neg_k, float2* out,
        long long n, int nh, int ny, double* part) {
    __shared__ double sh[BLOCK];
    double sks = 0.0;
    LOOP(n) {
        double w = rfft_weight(i, nh, ny);
        float2 c = st[i];
        float k = neg_k[i];
        out[i] = make_float2(c.x * k, c.y * k);
        double cr = c.x, ci = c.y;
        sks -= w * (double)k * (cr * cr + ci * ci);
    }
    PUT(0, 0, sks);
}

extern "C" __global__ void max_abs(const float* a, long long n, double* part) {
    __shared__ double sh[BLOCK];
    double m = 0.0;
    LOOP(n) { m = maxnan(m, fabs((double)a[i])); }
    PUT(0, 1, m);
}

extern "C" __global__ void max_abs_free(const float* a, const bool* active, long long n,
        double* part) {
    __shared__ double sh[BLOCK];
    double m = 0.0;
    LOOP(n) { if (!active[i]) m = maxnan(m, fabs((double)a[i])); }
    PUT(0, 1, m);
}
"""


@functools.lru_cache(maxsize=1)
def _module():
    cp = gpu.cupy()
    return cp.RawModule(code=_SOURCE, options=("--std=c++14",))


def _run(name: str, n: int, nresults: int, *args, extra: tuple = ()) -> np.ndarray:
    """Launch kernel ``name`` over n elements (its arguments: ``args``, n, ``extra``, the
    partials); its per-block partials, (nresults, blocks), on the host."""
    cp = gpu.cupy()
    blocks = max(1, min(MAX_BLOCKS, math.ceil(n / BLOCK)))
    part = cp.empty(nresults * blocks, dtype=np.float64)
    _module().get_function(name)((blocks,), (BLOCK,), (*args, np.int64(n), *extra, part))
    return part.get().reshape(nresults, blocks)


def _run_spectral(name: str, a, nresults: int, ny: int, *args) -> np.ndarray:
    """:func:`_run` over the rfft2 grid of ``a``: the spectral kernels also take the row
    length nh and ``ny`` (for the column weights)."""
    return _run(name, a.size, nresults, *args, extra=(np.int32(a.shape[1]), np.int32(ny)))


def cg_update(g, f, d, fks, t, alpha, eps, r, active):
    """:func:`_kernels.cg_update` on the GPU."""
    part = _run("cg_update", g.size, 1, g, f, d, fks, np.float64(t), np.float64(alpha),
                np.float64(eps), r, active)
    return float(part[0].sum())


def cg_precondition(rt, pre, rt_old, out, ny):
    """:func:`_kernels.cg_precondition` on the GPU."""
    part = _run_spectral("cg_precondition", rt, 2, ny, rt, pre, rt_old, out)
    return float(part[0].sum()), float(part[1].sum())


def cg_direction(z, d, g, f, beta, alpha, s_in, active):
    """:func:`_kernels.cg_direction` on the GPU."""
    part = _run("cg_direction", g.size, 4, z, d, g, f, np.float64(beta), np.float64(alpha),
                s_in, active)
    return int(part[0].sum()), float(part[1].sum()), float(part[2].max()), float(part[3].max())


def cg_feasible(g, d, alpha):
    """:func:`_kernels.cg_feasible` on the GPU."""
    return float(_run("cg_feasible", g.size, 1, g, d, np.float64(alpha))[0].min())


def cg_stiffness(st, neg_k, out, ny):
    """:func:`_kernels.cg_stiffness` on the GPU."""
    return float(_run_spectral("cg_stiffness", st, 1, ny, st, neg_k, out)[0].sum())


def max_abs(a):
    """:func:`_kernels.max_abs` of a float32 array on the GPU."""
    return float(_run("max_abs", a.size, 1, a)[0].max())


def max_abs_free(a, active):
    """:func:`_kernels.max_abs_free` of a float32 array on the GPU."""
    return float(_run("max_abs_free", a.size, 1, a, active)[0].max())


#: The solver's kernels in ``gfmd._hard_wall``'s order; ``cg_finish`` (once per solve) is
#: the array-module twin.
HARD_WALL = (cg_update, cg_precondition, cg_direction, cg_feasible, cg_stiffness,
             _kernels.cg_finish_np, max_abs, max_abs_free)
