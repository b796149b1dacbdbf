"""The ensemble path's memory kept between runs (gw_ensemble_new / gw_ensemble_run_in, a context
per run in flight, taylor/ensemble.py): runs of one Ensemble reuse the lanes' instances and
the batch memory, so nothing of one run may reach the next, and runs from several threads at
once must each have their own context.  Also the step size passes on made-up series
(tests/c/test_ens_passes.c)."""
from __future__ import annotations

import os
import shutil
import subprocess
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from c_programs import C_SRC, STRICT, TESTS_C
from gyrowheel.taylor.ensemble import STATUS_ERROR, STATUS_OK, Ensemble, library_source
from taylor_helpers import same_results as _same


@pytest.fixture(scope="module")
def paper(example_build):
    return example_build("paper_earth", taylor=True)


# 7 trajectories (some fall, at different times) on a grid, then jobs that leave a context in
# another state: fewer lanes busy, a trajectory failing at initialisation and one in its steps,
# another tolerance (another order: the series blocks' stride), no grid
JOB = dict(parameters={"g": [9.81, 3.721, 9.81, 9.81, 0.0, 9.81, 5.0], "beta_min": 0.1},
           starts={"gamma_dot": [6.0, 6.0, 1.0, 0.5, 3.0, 8.0, 0.2]}, rel_tol=1e-9,
           grid=np.linspace(0.5, 6.0, 12))
OTHERS = [dict(parameters={"M": [2.0, -1.0]}, rel_tol=1e-6),
          dict(starts={"gamma_dot": [6.0, 1e9, 6.0]}, rel_tol=1e-12),
          dict(starts={"gamma_dot": [4.0]}, rel_tol=1e-4)]


def test_runs_reusing_a_context_equal_fresh_runs(paper, tmp_path):
    """A job run after others on the same Ensemble (one context, reused) returns what it
    returns on a fresh Ensemble, bit for bit, messages included; the other jobs' messages stay
    with their own results."""
    fresh = Ensemble(paper.fmu, cache=tmp_path).run(6.0, **JOB)
    assert 0 < fresh.terminated.sum() < 7 and set(fresh.status) <= {STATUS_OK, 2}
    ens = Ensemble(paper.fmu, cache=tmp_path)
    first = ens.run(6.0, **JOB)
    _same(first, fresh)
    for other in OTHERS:
        res = ens.run(2.0, **other)
        assert len(ens._contexts) == 1  # the same context each time
        assert all(m.startswith("ensemble trajectory ") for m in res.messages)
        assert bool(res.messages) == (STATUS_ERROR in res.status)
        _same(ens.run(6.0, **JOB), fresh)


def test_runs_from_several_threads_have_their_own_contexts(paper, tmp_path):
    """The sweep engine may call one Ensemble from several threads (the C call releases the
    GIL): each run takes a context of its own from the pool, so concurrent runs return what
    one run alone returns."""
    ens = Ensemble(paper.fmu, cache=tmp_path)
    alone = ens.run(6.0, **JOB)
    with ThreadPoolExecutor(4) as pool:
        results = list(pool.map(lambda _: ens.run(6.0, **JOB), range(8)))
    for res in results:
        _same(res, alone)
    assert 1 <= len(ens._contexts) <= 4


DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
static int n_log;
static void logger(void *env, const char *who, gw_status st, const char *cat, const char *msg) {
    (void)env, (void)who, (void)st, (void)cat, (void)msg;
    n_log++;
}
static void set(int kind, int count, double *row, const char *name, double v) {
    int i;
    for (i = 0; i < count; i++)
        if (!strcmp(ID(name)(kind, i), name)) row[i] = v;
}
int main(void) {
    enum { N = 7, G = 12 };
    const double g[N] = {9.81, 3.721, 9.81, 9.81, 0.0, 9.81, 5.0}, spin[N] = {6, 6, 1, 0.5, 3, 8, 0.2};
    int sz[8], k, rep, status[N], flags[N * 16];
    static double P[N * 64], S[N * 64], tf[N], xf[N * 64], yf[N * 256], yg[N * (G + 1) * 256];
    double span[2] = {0.0, 6.0}, tol[3] = {1e-9, 1e-11, 6.0}, grid[G];
    unsigned long steps[N];
    long rows[N];
    void *ctx = ID(new)();
    ID(sizes)(sz);
    for (k = 0; k < G; k++) grid[k] = 0.5 * (k + 1);
    for (k = 0; k < N; k++) {
        ID(defaults)(P + k * sz[3], S + k * sz[1]);
        set(0, sz[3], P + k * sz[3], "g", g[k]);
        set(0, sz[3], P + k * sz[3], "beta_min", 0.1);
        set(1, sz[1], S + k * sz[1], "gamma_dot", spin[k]);
    }
    set(0, sz[3], P + 6 * sz[3], "M", -1.0); /* refused at initialisation */
    for (rep = 0; rep < 3; rep++) { /* a context reused, another order, no context */
        void *c = rep == 2 ? NULL : ctx;
        tol[0] = 1e-9;
        if (ID(run)(c, N, P, S, span, tol, status, tf, xf, yf, steps, logger, G, grid, yg, rows, flags))
            return 1;
        printf("%d %d %d %lu %.17g\n", status[0], status[2], status[6], steps[0], xf[0]);
        if (rep == 0) { /* the same job through run_packed, in a buffer of exactly the size and
                         * at the places the library exports (ID(layout), gw_ensemble_lib.c) */
            const size_t ne = sz[7] > 0 ? (size_t)sz[7] : 1;
            long at[GW_LIB_N_SECTIONS];
            double *f;
            char *b;
            const long *lg_steps, *lg_rows, *lg_status;
            const unsigned char *fl;
            const double *f_tf, *f_xf;
            if (ID(layout)(N, G, at) != GW_LIB_N_SECTIONS) return 4;
            if (!(f = malloc((size_t)at[GW_LIB_AT_end]))) return 1;
            b = (char *)f;
            memcpy(f, span, sizeof span);
            memcpy(f + 2, tol, sizeof tol);
            memcpy(b + at[GW_LIB_AT_grid], grid, sizeof grid);
            memcpy(b + at[GW_LIB_AT_p], P, sizeof(double) * N * sz[3]);
            memcpy(b + at[GW_LIB_AT_s], S, sizeof(double) * N * sz[1]);
            if (ID(run_packed)(ctx, N, G, f, logger)) return 1;
            lg_steps = (const long *)(void *)(b + at[GW_LIB_AT_steps]);
            lg_rows = (const long *)(void *)(b + at[GW_LIB_AT_n_rows]);
            lg_status = (const long *)(void *)(b + at[GW_LIB_AT_status]);
            fl = (const unsigned char *)(b + at[GW_LIB_AT_flags]);
            f_tf = (const double *)(void *)(b + at[GW_LIB_AT_t_final]);
            f_xf = (const double *)(void *)(b + at[GW_LIB_AT_x_final]);
            for (k = 0; k < N; k++)
                if (lg_status[k] != status[k] || (unsigned long)lg_steps[k] != steps[k] || lg_rows[k] != rows[k]
                    || fl[k * ne] != (flags[k * sz[7]] != 0) || f_xf[k * sz[0]] != xf[k * sz[0]]
                    || f_tf[k] != tf[k])
                    return 3;
            free(f);
            /* the kernel timed on this context (gyrowheel.taylor.lanes): the next runs the same */
            if (ID(kernel_calls)(ctx, 1e-14, 3, xf, yf, P) || ID(kernel_calls)(ctx, 0.0, 3, xf, yf, P) != -1)
                return 5;
        }
        tol[0] = rep == 0 ? 1e-12 : 1e-5;
        if (ID(run)(c, 3, P, S, span, tol, status, tf, xf, yf, steps, logger, 0, NULL, NULL, NULL, flags))
            return 1;
    }
    ID(free)(ctx);
    return n_log > 0 ? 0 : 2;
}
"""


def test_ensemble_library_clean_under_sanitizers(paper, tmp_path):
    """The ensemble library (contexts reused across runs of other sizes and orders, the lanes'
    series fetched lazily through event location, falls, a refused trajectory, a grid; the
    same job through run_packed in a buffer of exactly its layout, equal; the kernel timed on a
    context at the highest order between its runs) runs clean
    under AddressSanitizer, LeakSanitizer and UndefinedBehaviorSanitizer; each run gives the
    same numbers."""
    from c_programs import MODE_FLAGS, SANITIZER_ENV
    src = paper.sources
    prog = tmp_path / "ens.c"
    prog.write_text(library_source(paper.identifier, 4)
                    + f"#define ID(name) {paper.identifier}_ensemble_##name\n" + DRIVER)
    exe = tmp_path / "ens"
    cmd = ["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", *MODE_FLAGS["sanitizers"], f"-I{src}",
           str(prog), "-lm", "-o", str(exe)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    r = subprocess.run([str(exe)], capture_output=True, text=True, timeout=600,
                       env=dict(os.environ, **SANITIZER_ENV))
    assert r.returncode == 0, r.stdout + r.stderr
    lines = r.stdout.splitlines()
    assert len(lines) == 3 and len(set(lines)) == 1, lines
    assert lines[0].split()[:3] == ["0", "2", "3"]  # runs to the end, falls, refused


@pytest.mark.parametrize("cc", [c for c in ("gcc", "clang") if shutil.which(c)])
def test_step_size_passes_equal_the_one_lane_formulas(cc, tmp_path):
    """gw_ens_norms (c_src/gw_ensemble_passes.h) on 200 made-up series of 4 lanes (coefficients
    over 40 decades, zero norms, an infinite or NaN derivative in a lane): every lane's norms and
    step size bit for bit those of solver taylor's one-lane formulas (gw_taylor_step,
    gw_taylor_step_size: gw_fm_step4 in 4-lane vectors against scalar gw_fm_step calls, and within
    its bound of the exact rule), and the order-1 flag that spares gw_taylor_attempt_size its copy
    zero exactly where the lane's derivatives are finite; gw_ens_defects bit for bit
    gw_taylor_defect's loop, a NaN defect component before finite ones included (were the later
    finite one to replace it, solver taylor would reject a step the pass accepts).  Compiled once:
    GW_TAYLOR_STEP_FM reaches only the rejection rule, which this program does not include."""
    exe = tmp_path / "passes"
    subprocess.run([cc, *STRICT, "-O2", f"-I{C_SRC}",
                    str(TESTS_C / "test_ens_passes.c"), "-lm", "-o", str(exe)], check=True)
    r = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "test_ens_passes: 0 failures" in r.stderr, r.stderr


class _Interrupt(Exception):
    """What the test's SIGINT handler raises (Ctrl-C's KeyboardInterrupt would stop pytest)."""


def test_context_back_in_the_pool_after_an_interrupted_run(paper, tmp_path):
    """Ctrl-C during a run: the signal's exception is raised as the C call returns, inside
    Ensemble.run; the context it took must go back to the pool (not be lost, never freed, a new
    one made by the next run), and the next run reuses it and equals a fresh run."""
    import signal
    import threading

    ens = Ensemble(paper.fmu, cache=tmp_path)
    fresh = Ensemble(paper.fmu, cache=tmp_path).run(6.0, **JOB)
    ens.run(6.0, **JOB)
    assert len(ens._contexts) == 1

    def interrupt(signum, frame):
        raise _Interrupt

    previous = signal.signal(signal.SIGINT, interrupt)
    try:
        timer = threading.Timer(0.02, signal.pthread_kill, (threading.main_thread().ident, signal.SIGINT))
        timer.start()
        with pytest.raises(_Interrupt):
            # about 0.1-0.5 s of C: the signal arrives inside the call
            ens.run(200.0, starts={"gamma_dot": np.full(64, 6.0)}, rel_tol=1e-12)
            timer.join()  # (a very fast machine: the signal after the run, still inside this block)
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert len(ens._contexts) == 1
    _same(ens.run(6.0, **JOB), fresh)
    assert len(ens._contexts) == 1


def test_default_tables_cache_cleared_by_another_thread(paper, tmp_path):
    """The defaults' tables are cached per N and the cache is cleared past 16 sizes; another
    thread's run may clear it between this run's test for a key and its read of it (a KeyError
    out of Ensemble.run).  The interleaving made deterministic: a cache whose membership test
    clears it, as the other thread would."""
    ens = Ensemble(paper.fmu, cache=tmp_path)
    alone = ens.run(2.0, starts={"gamma_dot": [6.0, 4.0, 2.0]}, rel_tol=1e-8)

    class ClearedMeanwhile(dict):
        def __contains__(self, key):
            found = dict.__contains__(self, key)
            self.clear()
            return found

        def get(self, key, default=None):
            found = dict.get(self, key, default)
            self.clear()
            return found

    ens._default_tables = ClearedMeanwhile(ens._default_tables)
    for _ in range(2):  # a table made by this run, then one found in the cache
        res = ens.run(2.0, starts={"gamma_dot": [6.0, 4.0, 2.0]}, rel_tol=1e-8)
        _same(res, alone)


def test_ensembles_made_at_once_by_threads_on_a_cold_cache(paper, tmp_path, monkeypatch):
    """Two threads of one process make an Ensemble of the same FMU at once, the library not yet
    in the cache: both compile it, and both must end with a working library (with one temporary
    file name for both, the second's rename fails with FileNotFoundError, or moves the other's
    half-written library into the cache).  Both compilers made to finish before either renames.
    The lane count is the CPU's here (ensemble_lanes' timing of two widths, under its lock, is
    tested in test_ensemble_lanes_cpu.py)."""
    import threading

    import gyrowheel.taylor.ensemble as ensemble_mod
    import gyrowheel.taylor.lanes as lanes_mod

    monkeypatch.setattr(lanes_mod, "ensemble_lanes",
                        lambda fmu, cache=None, defines=None, check=True: lanes_mod.cpu_lanes(cache))

    barrier = threading.Barrier(2, timeout=300)
    compile_shared = ensemble_mod.compile_shared

    def compile_then_wait(*args, **kwargs):
        out = compile_shared(*args, **kwargs)
        barrier.wait()
        return out

    monkeypatch.setattr(ensemble_mod, "compile_shared", compile_then_wait)
    cache = tmp_path / "cold"
    with ThreadPoolExecutor(2) as pool:
        runs = list(pool.map(lambda _: Ensemble(paper.fmu, cache=cache).run(2.0, **OTHERS[2]), range(2)))
    _same(runs[0], runs[1])
    assert runs[0].status[0] == STATUS_OK
    # the library and the CPU's lane-count probe (gyrowheel.taylor.lanes), no half-written file
    assert sorted(p.name for p in cache.rglob("*") if p.is_file()) == ["libcpulanes.so", "libensemble.so"]


def test_runs_of_other_sizes_equal_fresh_runs_and_keep_their_results(paper, tmp_path):
    """Ensemble.run keeps its buffer layout per (N, grid size) and the C side writes status and
    flags into the buffer in the types handed out: a sequence of jobs with other N, with and
    without a grid, other starts and parameters, on one Ensemble returns what each returns on
    a fresh Ensemble (bit for bit, the same dtypes), and a later run leaves the arrays of an
    earlier result as they were (each result owns its buffer)."""
    jobs = [JOB, *OTHERS, dict(starts={"gamma_dot": [6.0, 5.0, 4.0, 3.0]}, rel_tol=1e-4),
            dict(parameters=np.tile(Ensemble(paper.fmu, cache=tmp_path).default_parameters, (5, 1)),
                 rel_tol=1e-7, grid=[0.5, 1.0, 2.0]),
            dict(starts={"gamma_dot": [6.0, 5.0, 4.0, 3.0]}, rel_tol=1e-4, grid=[1.0, 2.0]), JOB]
    ens = Ensemble(paper.fmu, cache=tmp_path)
    kept = []
    for job in jobs:
        t_end = 6.0 if job is JOB else 2.0
        res, fresh = ens.run(t_end, **job), Ensemble(paper.fmu, cache=tmp_path).run(t_end, **job)
        _same(res, fresh)
        for name in ("status", "steps", "flags", "t_final", "x_final", "y_final", "n_rows", "y_grid"):
            a, b = getattr(res, name), getattr(fresh, name)
            assert (a is None) == (b is None) and (a is None or (a.dtype == b.dtype and a.shape == b.shape))
        assert res.status.dtype == np.int_ and res.steps.dtype == np.int64 and res.flags.dtype == bool
        assert res.flags.shape == (len(res.status), len(ens.event_names)) and res.x_final.flags.writeable
        np.testing.assert_array_equal(res.y_final, fresh.y_final)
        np.testing.assert_array_equal(res.n_rows, fresh.n_rows)
        kept.append((res, {k: np.copy(getattr(res, k)) for k in ("status", "steps", "flags", "t_final",
                                                                 "x_final", "y_final", "y_grid")}))
    assert sorted(ens._layouts) == [(1, 0), (2, 0), (3, 0), (4, 0), (4, 2), (5, 3), (7, 12)]
    for res, copies in kept:
        for name, value in copies.items():
            np.testing.assert_array_equal(getattr(res, name), value)


def _rows(res, idx):
    """The result of trajectories idx as a result of their own (for _same)."""
    from types import SimpleNamespace
    return SimpleNamespace(status=res.status[idx], steps=res.steps[idx], t_final=res.t_final[idx],
                           x_final=res.x_final[idx], n_rows=None if res.n_rows is None else res.n_rows[idx],
                           y_grid=None if res.y_grid is None else res.y_grid[idx], flags=res.flags[idx],
                           messages=[])


@pytest.mark.parametrize("lanes", [4, 8])
def test_a_trajectory_has_the_same_bits_in_any_batch(paper, tmp_path, lanes):
    """A trajectory's steps and values depend on it alone, not on the trajectories beside it
    (docs/sweeps.md 'Determinism': a sweep's ensemble path gives a point the same bits whatever
    the batch size and the order): 11 trajectories (falls at different times, so the job ends
    with few lanes active) each equal, bit for bit, to its run alone and in the reversed job,
    with and without a grid.  The one-lane kernel for a job's tail (GW_ENSEMBLE_SINGLE_MAX > 0)
    breaks this: the library's FMA contraction rounds it unlike the lane kernel (a lone
    trajectory 1e-13 from itself in a batch; a sweep's fall_time, min_beta, final_x ... apart
    between batch_size 14 and 1)."""
    ens = Ensemble(paper.fmu, lanes=lanes, cache=tmp_path)
    g = np.array([9.81, 3.721, 9.81, 9.81, 0.0, 9.81, 5.0, 1.625, 9.81, 2.0, 9.81])
    spin = np.array([6.0, 6.0, 1.0, 0.5, 3.0, 8.0, 0.2, 11.0, 0.8, 6.0, 2.5])
    n = len(g)
    for extra in ({}, {"grid": np.linspace(0.3, 6.0, 20)}):
        kw = dict(rel_tol=1e-9, **extra)
        full = ens.run(6.0, parameters={"g": g, "beta_min": 0.3}, starts={"gamma_dot": spin}, **kw)
        assert 2 <= full.terminated.sum() < n
        back = ens.run(6.0, parameters={"g": g[::-1], "beta_min": 0.3}, starts={"gamma_dot": spin[::-1]}, **kw)
        _same(_rows(back, slice(None, None, -1)), _rows(full, slice(None)))
        for j in range(n):
            alone = ens.run(6.0, parameters={"g": g[j:j + 1], "beta_min": 0.3}, starts={"gamma_dot": spin[j:j + 1]}, **kw)
            _same(_rows(alone, slice(0, 1)), _rows(full, slice(j, j + 1)))


@pytest.mark.parametrize("cc", [c for c in ("gcc", "clang") if shutil.which(c)])
def test_increments_pass_equals_the_one_lane_increment(paper, tmp_path, cc):
    """gw_ens_increments (dx and P'(h) of all lanes) bit for bit gw_taylor_increment lane by lane,
    compiled as the ensemble library is (its unity file and flags: FMA contraction in the
    x86-64-v3 clones), on random series (tests/c/test_ens_increments.c).  A pass fusing two sums
    fewer gives dx apart in 1.2% of the components, P'(h) in 20%, and inline lane-steps 1-2 ulp
    apart from those of the GW_ENSEMBLE_LANE_STEPS=1 build (paper, gamma_dot 1e5 at rel_tol
    1e-4, slope_hold at 1e-3)."""
    from gyrowheel.taylor.ensemble import FLAGS
    prog = tmp_path / "incr.c"
    prog.write_text(library_source(paper.identifier, 4) + '#include "test_ens_increments.c"\n')
    exe = tmp_path / "incr"
    subprocess.run([cc, *STRICT, *FLAGS, f"-I{paper.sources}", f"-I{TESTS_C}", str(prog), "-lm", "-o", str(exe)],
                   check=True)
    r = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr
    assert "dx differ 0, P'(h) differ 0" in r.stdout


def test_lane_counts_two_and_more_give_the_same_bits(paper, tmp_path):
    """Ensemble(fmu, lanes=3 / 8 / 16), 4 and the machine's default (gyrowheel.taylor.lanes), and 8 lanes in slices of 8 and of 4 doubles (GW_ENSEMBLE_AVX512 1
    and 0, whatever the CPU): the same steps and values bit for bit (each
    lane's kernel slice and passes do the same operations, and a job's tail stays in the lane
    kernel: with the one-lane tail kernel, GW_ENSEMBLE_SINGLE_MAX 1 of 3 and 6 of 16, the widths
    are 1e-13 apart in some trajectories).  lanes = 1 runs the scalar kernel, contracted
    otherwise: equal to rounding
    (tests/test_ensemble_runs.py::test_ensemble_lanes_tail_and_refill_equal_the_single_runs)."""
    rng = np.random.default_rng(5)  # 13 trajectories, 5 of which the one-lane tail kernel sets apart
    starts = {"gamma_dot": rng.uniform(0.5, 12.0, 13), "beta": rng.uniform(0.9, 1.55, 13)}
    for extra in ({}, {"grid": np.linspace(0.3, 6.0, 20)}):
        kw = dict(parameters={"beta_min": np.full(13, 0.3)}, starts=starts, rel_tol=1e-9, **extra)
        ref = Ensemble(paper.fmu, lanes=4, cache=tmp_path).run(6.0, **kw)
        assert 0 < ref.terminated.sum() < 13
        for lanes in (3, 8, 16, None):
            _same(Ensemble(paper.fmu, lanes=lanes, cache=tmp_path).run(6.0, **kw), ref)
        for wide in (0, 1):
            ens = Ensemble(paper.fmu, lanes=8, cache=tmp_path, defines={"GW_ENSEMBLE_AVX512": wide})
            _same(ens.run(6.0, **kw), ref)
