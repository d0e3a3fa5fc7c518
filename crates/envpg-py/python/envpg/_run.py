"""Training, the oracle and exact evaluation: the CLI's programs run on argument lists built
from keyword arguments, so every setting means what its ``--option`` means and is checked the
same way."""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import secrets
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

from . import _native
from ._instance import Instance
from ._native import EnvError, InputError, RunError
from ._pyenv import instance_of, python_path
from ._result import Result, load_result

#: Set in a run's own processes (``python -m envpg._launch`` / ``_tools``): a module they import
#: to rebuild the environment must not start runs of its own.
IN_RUN_PROCESS = False


def planned_iterations(run: Mapping[str, Any]) -> int:
    """The iterations a run (its ``run.json``) trains over all its passes: a warm pass trains
    the last quarter of the schedule only (``WARM_FRACTION`` in envpg-launch's passes.rs), and
    is every pass after the first with ``pass_start="warm"``, every pass after the first half
    (rounded up) with ``"portfolio"``."""
    iterations = run["spec"]["config"]["iterations"]
    passes, start = run.get("passes", 1), run.get("pass_start")
    full = min(passes, {"warm": 1, "portfolio": (passes + 1) // 2}.get(start, passes))
    return full * iterations + (passes - full) * math.ceil(0.25 * iterations)


def _not_in_a_run_process(what: str) -> None:
    if IN_RUN_PROCESS:
        raise RuntimeError(
            f"envpg.{what} was called while a run's process imported the environment's module: put the "
            "script's work under `if __name__ == \"__main__\":` (each process of a run imports it)"
        )


#: How the launcher starts a run's learner and workers from Python.
PROGRAM = [sys.executable, "-m", "envpg._launch"]
DISPLAY = "python -m envpg._launch"


def _flags(settings: Mapping[str, Any]) -> list[str]:
    """``--option value`` arguments of keyword settings (``polish_iterations=0`` →
    ``--polish-iterations 0``; ``True`` → a bare flag; lists comma-separated)."""
    out: list[str] = []
    for key, value in settings.items():
        if value is None or value is False:
            continue
        flag = "--" + key.replace("_", "-")
        if value is True:
            out.append(flag)
        elif isinstance(value, (list, tuple)):
            out += [flag, ",".join(_text(v, key) for v in value)]
        else:
            out += [flag, _text(value, key)]
    return out


def _text(value: Any, key: str) -> str:
    if isinstance(value, float):
        if not math.isfinite(value):
            raise InputError(f"{key}={value!r}: must be finite")
        return repr(value)
    if isinstance(value, (int, str, os.PathLike)):
        return os.fspath(value) if isinstance(value, os.PathLike) else str(value)
    raise InputError(f"{key}={value!r}: a setting is a number, a string, a bool or a list of numbers")


@contextlib.contextmanager
def _instance_arg(instance: Any) -> Iterator[str]:
    """The ``--instance`` argument for a name, a path, an :class:`Instance` or a Python
    environment object (the last two through a temporary file)."""
    if isinstance(instance, str):
        yield instance
        return
    if isinstance(instance, os.PathLike):
        yield os.fspath(instance)
        return
    data = instance.data if isinstance(instance, Instance) else instance_of(instance)
    with tempfile.TemporaryDirectory(prefix="envpg-") as d:
        path = Path(d) / "instance.json"
        path.write_text(json.dumps(data))
        yield str(path)


@contextlib.contextmanager
def _run_context() -> Iterator[None]:
    """What a run changes in this interpreter, restored afterwards: ``PYTHONPATH`` (the run's
    processes import what this interpreter can) and the SIGINT/SIGTERM handlers (the launcher
    takes them while it supervises)."""
    old_path = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = python_path()
    main = threading.current_thread() is threading.main_thread()
    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)} if main else {}
    try:
        yield
    finally:
        if old_path is None:
            os.environ.pop("PYTHONPATH", None)
        else:
            os.environ["PYTHONPATH"] = old_path
        for s, h in handlers.items():
            signal.signal(s, h if h is not None else signal.SIG_DFL)


def _runs_dir() -> Path:
    base = os.environ.get("ENVPG_RUNS_DIR")
    return Path(base) if base else Path.cwd() / "runs"


def _tqdm(enabled: bool | None) -> Any:
    """tqdm's bar class when progress is wanted (``None``: if tqdm is installed), else ``None``."""
    if enabled is False:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        if enabled:
            raise InputError("progress=True needs tqdm (pip install tqdm)") from None
        return None
    return tqdm


class _Progress:
    """A tqdm bar fed from the run's ``metrics.csv`` (a row per completed iteration), if tqdm is
    installed and progress is wanted."""

    def __init__(self, run_dir: Path, enabled: bool | None):
        self.run_dir = run_dir
        self.stop = threading.Event()
        self.thread = None
        tqdm = _tqdm(enabled)
        if tqdm is None:
            return
        self.tqdm = tqdm
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        bar = None
        shown = 0
        while True:
            done = self.stop.wait(0.2)
            try:
                if bar is None:
                    run = json.loads((self.run_dir / "run.json").read_text())
                    bar = self.tqdm(total=planned_iterations(run), desc="envpg", unit="it")
                # A run of several passes (``passes=N``) keeps each pass's metrics in pass-P/.
                rows = 0
                for metrics in [self.run_dir / "metrics.csv", *self.run_dir.glob("pass-*/metrics.csv")]:
                    if metrics.exists():
                        with open(metrics) as f:
                            rows += max(sum(1 for _ in f) - 1, 0)
                if rows > shown:
                    bar.update(rows - shown)
                    shown = rows
            except (OSError, ValueError, KeyError):
                pass
            if done:
                break
        if bar is not None:
            bar.close()

    def close(self) -> None:
        if self.thread is not None:
            self.stop.set()
            self.thread.join()


def _launch(argv: list[str], run_dir: Path, progress: bool | None) -> None:
    bar = _Progress(run_dir, progress)
    try:
        with _run_context():
            _native.launch(["envpg-launch", *argv], PROGRAM, DISPLAY)
    finally:
        bar.close()


def train(
    instance: Any = "uav271",
    *,
    workers: int = 2,
    seed: int = 1,
    preset: str | None = None,
    in_process: bool = False,
    out: str | os.PathLike[str] | None = None,
    run_dir: str | os.PathLike[str] | None = None,
    progress: bool | None = None,
    **settings: Any,
) -> Result:
    """Trains a policy and the design together with Algorithm 1 — exactly ``envpg-launch``:
    the same seed and settings give the same result, bit for bit.

    ``instance`` is a bundled name, a path, an :class:`Instance`, or an environment object
    written in Python (:class:`envpg.Env`), whose workers are Python processes stepping it.
    ``workers`` rollout-worker processes (threads with ``in_process=True``) run beside the
    learner. ``settings`` are ``envpg-launch``'s options by keyword (``iterations=200``,
    ``polish_iterations=0``, ``hidden=[64, 64]``, ``checkpoint_every=10``,
    ``tensorboard="tb"``, ``env_param=["kappa=0.9"]``); an unknown one raises
    :class:`InputError`.

    The run lives in ``run_dir`` (default ``runs/<id>`` under ``$ENVPG_RUNS_DIR`` or the
    current directory: run.json, metrics.csv, log.txt, checkpoint.bin, result.json); the
    result is also written to ``out`` if given. The GIL is released while it runs; with tqdm
    installed a progress bar follows the iterations (``progress=False``: none).

    Raises :class:`InputError` (bad input, before any work), :class:`EnvError` (a Python
    environment raised or returned garbage: its traceback), :class:`RunError`, or
    ``KeyboardInterrupt`` on Ctrl-C — every process of the run stopped, its shared memory
    removed, a checkpoint kept for :func:`resume`."""
    _not_in_a_run_process("train")
    if not isinstance(instance, (str, os.PathLike, Instance)) and in_process:
        raise InputError(
            "a Python environment is stepped by worker processes: train it without in_process=True"
        )
    if isinstance(workers, bool) or not isinstance(workers, int):
        raise InputError(f"workers={workers!r}: must be an integer")
    directory = Path(run_dir) if run_dir is not None else _runs_dir() / secrets.token_hex(6)
    with _instance_arg(instance) as spec:
        argv = ["--instance", spec, "--workers", str(workers), "--seed", str(seed), "--quiet"]
        argv += ["--run-dir", str(directory), "--out", str(Path(out) if out is not None else directory / "result.json")]
        argv += _flags({"preset": preset, "in_process": in_process, **settings})
        _launch(argv, directory, progress)
    result = load_result(Path(out) if out is not None else directory / "result.json")
    result.run_dir = directory
    return result


def resume(run_dir: str | os.PathLike[str], *, progress: bool | None = None) -> Result:
    """Continues an interrupted run from its last checkpoint (as ``envpg-launch --resume
    DIR``); the result is the one the run would have given uninterrupted."""
    _not_in_a_run_process("resume")
    directory = Path(run_dir)
    _launch(["--resume", str(directory)], directory, progress)
    result = load_result(directory / "result.json")
    result.run_dir = directory
    return result


def oracle(
    instance: Any = "uav271",
    *,
    restarts: int = 16,
    seed: int = 1,
    out: str | os.PathLike[str] | None = None,
    progress: bool | None = None,
    **settings: Any,
) -> Result:
    """The model-based oracle: annealed co-design with exact gradients, best of ``restarts``
    — exactly ``envpg oracle``. ``settings`` are its options by keyword (``strategy="warm"``,
    ``threads=1``, ``init=[...]``). Runs in a child process, so Ctrl-C stops it at once; with
    tqdm installed a bar counts the restarts and kicks as they end and shows the best J so far
    (``progress=False``: none)."""
    _not_in_a_run_process("oracle")
    tqdm = None if settings.get("quiet") else _tqdm(progress)
    with tempfile.TemporaryDirectory(prefix="envpg-oracle-") as d:
        target = Path(out) if out is not None else Path(d) / "oracle.json"
        with _instance_arg(instance) as spec:
            argv = ["oracle", "--instance", spec, "--restarts", str(restarts), "--seed", str(seed)]
            argv += ["--out", str(target), *_flags(settings)]
            if tqdm is None:
                _tools(argv)
            else:
                bar = tqdm(total=restarts, desc="envpg oracle", unit="restart")
                try:
                    _tools([*argv, "--progress-lines"], on_progress=lambda total, best: _advance(bar, total, best))
                finally:
                    bar.close()
        result = load_result(target)
        if out is None:
            result.path = None
        return result


def _advance(bar: Any, total: int, best: float) -> None:
    """One more restart or kick of ``total`` has ended; the best J so far is ``best``."""
    bar.total = total
    bar.set_postfix(best_J=f"{best:.6f}", refresh=False)
    bar.update(1)


#: A line ``envpg oracle --progress-lines`` writes as a restart or kick ends.
_ORACLE_LINE = re.compile(r"^envpg oracle: \d+/(\d+) ended, .*best J = (\S+),")


def _tools(argv: list[str], on_progress: Callable[[int, float], None] | None = None) -> str:
    """Runs ``envpg ARGV`` as ``python -m envpg._tools``; returns its stdout, raises on failure
    with its error message. With ``on_progress``, each progress line the oracle writes on
    stderr is passed on as (restarts and kicks in all, best J so far) instead."""
    env = dict(os.environ, PYTHONPATH=python_path())
    proc = subprocess.Popen(
        [sys.executable, "-m", "envpg._tools", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        if on_progress is None:
            stdout, stderr = proc.communicate()
        else:
            stdout, stderr = _follow(proc, on_progress)
    except BaseException:
        proc.terminate()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        raise
    if proc.returncode == 0:
        if stderr:
            sys.stderr.write(stderr)
        return stdout
    message = "\n".join(line.removeprefix("error: ") for line in stderr.strip().splitlines()) or f"exit code {proc.returncode}"
    if proc.returncode == 2:
        raise InputError(message)
    if proc.returncode == 4:
        raise EnvError(message)
    raise RunError(message)


def _follow(proc: subprocess.Popen[str], on_progress: Callable[[int, float], None]) -> tuple[str, str]:
    """Reads ``proc``'s stderr line by line as it comes, passing progress lines to
    ``on_progress`` and keeping the rest; stdout is read beside it so neither pipe fills."""
    assert proc.stdout is not None and proc.stderr is not None
    chunks: list[str] = []
    reader = threading.Thread(target=lambda: chunks.append(proc.stdout.read()), daemon=True)
    reader.start()
    kept = []
    for line in proc.stderr:
        m = _ORACLE_LINE.match(line)
        if m:
            on_progress(int(m.group(1)), float(m.group(2)))
        else:
            kept.append(line)
    reader.join()
    proc.wait()
    return "".join(chunks), "".join(kept)


def evaluate(result: Result | str | os.PathLike[str]) -> float | None:
    """The exact J of a result (a :class:`Result` or a result file), recomputed from its own
    contents — environment, full instance, ζ and policy — not read from its ``J``. ``None``
    when the policy does not terminate from some state. Raises :class:`InputError` for an
    environment without a model."""
    if isinstance(result, Result):
        return result.evaluate()
    return load_result(result).evaluate()


def check_env(
    env: Any,
    zeta: Any = None,
    *,
    h: float = 1e-6,
    tol: float = 1e-6,
    states: Any = (),
    samples: int = 0,
) -> None:
    """envpg's environment checks on an environment's model at design ``zeta`` (default: its
    initial design, or the centre of its bounds): every ∂p/∂ζ and ∂c/∂ζ of ``outcomes``
    against central differences (step ``h``, relative tolerance ``tol``), and, with
    ``samples`` > 0, ``step``'s frequencies from every valid action of each state in
    ``states`` against ``outcomes``' probabilities. ``env`` is a Python environment object,
    an :class:`Instance` or an instance name. Raises :class:`EnvCheckError` (an
    ``AssertionError``) naming the state, action, outcome and coordinate that disagree."""
    from ._instance import load_instance

    data = instance_of(env) if not isinstance(env, (str, os.PathLike, Instance)) else load_instance(env).data
    text = json.dumps(data)
    if zeta is None:
        zeta = _native.Sampler(text).initial_design()
    z = [float(x) for x in zeta]
    _native.check_env(text, z, float(h), float(tol), [int(s) for s in states], int(samples))
