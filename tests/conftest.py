"""Shared test settings and strategies."""

import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from threadpoolctl import threadpool_limits

import haptex as hx

# BLAS on one thread in the tests: pytest-xdist runs one worker per core, and each worker's
# OpenBLAS (numpy's and scipy's) otherwise starts a thread per core that spins after each call,
# taking the other worker's core (measured: test_core.py and test_surfaces.py on two workers,
# 91 s with BLAS's default threads, 69 s with one). Set before the workers and the CLI's
# subprocesses start, which inherit it; the libraries already loaded (numpy, by pytest's
# plugins) are held by threadpoolctl. The tests assert results, never BLAS's speed.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

threadpool_limits(1)

settings.register_profile(
    "haptex",
    deadline=None,
    max_examples=int(os.environ.get("HAPTEX_HYPOTHESIS_EXAMPLES", "40")),
    suppress_health_check=[HealthCheck.too_slow],
    # the same examples on every run, so that CI's verdict is reproducible; explore new ones
    # with HAPTEX_HYPOTHESIS_RANDOM=1 (and more with HAPTEX_HYPOTHESIS_EXAMPLES)
    derandomize=os.environ.get("HAPTEX_HYPOTHESIS_RANDOM", "") != "1",
)
settings.load_profile("haptex")

# The paper's Section V-A parameters.
K0 = 2000.0  # N/m
A = 0.8e-3  # m
L = 1e-3  # m


@st.composite
def textures(draw, max_components=3):
    """Random sums of sinusoids with commensurate periods between 0.5 mm and 4 mm and
    slopes up to about 6 (the paper's sinusoid has 2 pi A / l = 5.03)."""
    n = draw(st.integers(1, max_components))
    base = draw(st.sampled_from([0.5e-3, 1e-3, 2e-3]))
    mult = draw(st.lists(st.integers(1, 4), min_size=n, max_size=n, unique=True))
    periods = [base * m for m in mult]
    amps = [draw(st.floats(0.02, 0.6)) * p / (2 * np.pi) * 2 for p in periods]
    phases = draw(st.lists(st.floats(0, 2 * np.pi), min_size=n, max_size=n))
    return hx.SumOfSinusoids(amps, periods, phases)


DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
DEKTAK = DATA / "dektak-stylus-profile.csv"
GROOVES = DATA / "grooves-4mm-profile.mat"
needs_data = pytest.mark.skipif(not DEKTAK.exists(), reason="../shared/data is not beside this checkout")


def explorer_process():
    """``haptex explore`` started on a free port in a subprocess, as a user runs it, once it
    answers: yields (port, process) and stops it after. Shared by the browser tests and the
    server's fuzz (a generator for a module-scoped fixture)."""
    import socket
    import subprocess
    import sys
    import time
    import urllib.request

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    # the server's output goes to a file, not a pipe nobody reads (a full pipe would block its
    # logging, and with it the server); a failing test quotes its tail (server_log)
    import tempfile

    log = tempfile.NamedTemporaryFile(prefix="haptex-explore-", suffix=".log", delete=False)
    proc = subprocess.Popen([sys.executable, "-m", "haptex", "explore", "--port", str(port), "--no-browser"],
                            stdout=log, stderr=subprocess.STDOUT)
    proc.log_path = log.name
    deadline = time.monotonic() + 60
    while True:
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=2).read(100)
            break
        except OSError:
            if proc.poll() is not None or time.monotonic() > deadline:
                proc.kill()
                proc.wait()
                pytest.fail(f"the explorer did not start: {server_log(proc)}")
            time.sleep(0.3)
    yield port, proc
    proc.terminate()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()
    log.close()
    Path(log.name).unlink(missing_ok=True)


def counting(monkeypatch, owner, name):
    """Patch ``owner.name`` (a function or method called as (first, points, ...)) to record how
    many points each call evaluates; returns that list of counts."""
    sizes = []
    real = getattr(owner, name)

    def counted(first, p, *a, **k):
        sizes.append(int(np.prod(np.shape(p)[:-1])))
        return real(first, p, *a, **k)
    monkeypatch.setattr(owner, name, counted)
    return sizes


def public_api():
    """(module name, name, object, its parameters' names) of every public function and class of
    the package's public modules, defined there (not imported), that has a signature: what the
    tests that check a list of public functions against the package walk."""
    import importlib
    import inspect
    import pkgutil

    for m in pkgutil.walk_packages(hx.__path__, "haptex."):
        if any(part.startswith("_") for part in m.name.split(".")[1:]):
            continue
        mod = importlib.import_module(m.name)
        for n, obj in vars(mod).items():
            if n.startswith("_") or not (inspect.isfunction(obj) or inspect.isclass(obj)) or obj.__module__ != m.name:
                continue
            try:
                params = list(inspect.signature(obj).parameters)
            except ValueError:  # (a class without a signature of its own)
                continue
            yield m.name, n, obj, params


def server_log(proc, chars: int = 3000) -> str:
    """The tail of an :func:`explorer_process` server's output (for a failing test's message)."""
    try:
        return Path(proc.log_path).read_text(errors="replace")[-chars:]
    except OSError as exc:
        return f"(no log: {exc})"


@pytest.fixture(scope="session")
def objdir(tmp_path_factory):
    """Where tests/cbuild.py compiles the C core's objects, once per flag set in a process."""
    return tmp_path_factory.mktemp("core-objects")


@pytest.fixture(scope="session")
def shared(tmp_path_factory):
    """``shared(key, make)``: ``make()`` computed once in a test run and read by every test that
    asks for the same ``key`` (a str naming everything the value depends on), across
    pytest-xdist's workers: a pickle in the directory the run's workers share (the parent of
    each worker's base temporary directory, pytest-xdist's documented pattern), written by the
    first worker to ask while the others wait on its lock (``fcntl.flock``). For deterministic
    values that cost seconds and that several tests read (a felt map, an oracle's q): each
    caller gets its own copy, unpickled, as ``make()`` returned it before any test used it, so
    one test's caches or changes never reach another. Measured on .ci/run's long set
    (2026-12-01): the felt maps several tests read were 83 s of its test time made again."""
    import fcntl
    import hashlib
    import pickle

    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent
    root = root / "shared"
    root.mkdir(exist_ok=True)

    def get(key: str, make):
        stem = root / hashlib.sha256(key.encode()).hexdigest()[:24]
        with open(stem.with_suffix(".lock"), "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # (released when the file closes)
            path = stem.with_suffix(".pkl")
            if path.exists():
                return pickle.loads(path.read_bytes())
            value = make()
            data = pickle.dumps(value)
            tmp = stem.with_suffix(".tmp")
            tmp.write_bytes(data)
            tmp.replace(path)
            return pickle.loads(data)

    return get
