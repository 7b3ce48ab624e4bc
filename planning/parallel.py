"""Independent work items on local processes or on Ray: the one scheduler of the long commands.

    results = run_items(fn, items, workers=1, use_ray=False, on_result=None)

`fn` is a module-level function (workers import it by name) and `items` picklable values;
the results come back in the items' order. Three ways to run them:

  workers=1          here, one after another: the serial run, nothing started.
  workers=N          a local pool of N spawned processes (no server), items handed out as
                     workers free up.
  use_ray=True       each item a Ray task (num_cpus=1, plain tasks, not Ray Tune).
                     `ray.init()` joins the cluster named by RAY_ADDRESS (uploading the
                     working directory, less .git, .venv and runs/, so the nodes run this
                     code; they need the project's dependencies installed), else starts a
                     local instance with N CPUs (all of them when N is 1), shut down at the end.
                     On the head node of a cluster started with `ray start --head`,
                     RAY_ADDRESS=auto; from another machine, RAY_ADDRESS=HEAD:6379 and, as
                     Ray's token authentication asks, RAY_AUTH_MODE=token with the head's
                     ~/.ray/auth_token copied over.

Every worker runs with one thread for torch, OpenMP and BLAS (`one_thread`; the serial run
too, so that both compute alike), and in the caller's working directory when that exists
there (relative paths mean the same). `on_result(i, result, meta)`
runs in this process as each item finishes (meta: the worker's host and pid, the item's
seconds), so the caller writes each item's file at once and a rerun skips what is done. A
failing item stops the run: the items not yet started are cancelled and its error is raised
here (a DomainError stays one line). A worker that dies (killed, out of memory: the pool's
BrokenProcessPool, Ray's WorkerCrashedError) is one DomainError line too, saying how many
items finished; their on_result has run, so a rerun of the command plays only the rest.
"""

from __future__ import annotations

import os
import socket
import sys
import time
from pathlib import Path

from tqdm import tqdm

from planning.errors import DomainError

RAY_EXCLUDES = [".git", ".venv", "runs", "__pycache__", "*.partial.json", "*.parts"]


_ONE_THREAD = False


def one_thread() -> None:
    """One thread for torch, OpenMP and BLAS in this process, set the same way here and in every worker.

    The thread count changes how floating-point sums are split, so a value computed with two
    threads differs in its last bits from one computed with one: the serial run and the workers
    must agree for their results to be identical. torch is imported first, so that its
    libraries are loaded when threadpoolctl limits every BLAS and OpenMP pool.
    """
    global _ONE_THREAD
    if _ONE_THREAD:
        return
    import torch
    from threadpoolctl import threadpool_limits

    torch.set_num_threads(1)
    threadpool_limits(1)
    _ONE_THREAD = True


def _worker_init(cwd: str) -> None:
    one_thread()
    if cwd and os.path.isdir(cwd):
        os.chdir(cwd)


def _call(fn, item, cwd: str | None = None):
    """Run one item in a worker: (result, meta)."""
    if cwd is not None:
        _worker_init(cwd)
    t0 = time.perf_counter()
    result = fn(item)
    return result, {"host": socket.gethostname(), "pid": os.getpid(), "seconds": round(time.perf_counter() - t0, 3)}


def describe(workers: int, use_ray: bool) -> str:
    """How items will run, in words (for a log line)."""
    if use_ray:
        where = os.environ.get("RAY_ADDRESS")
        return (
            f"Ray tasks on {where}"
            if where
            else f"Ray tasks on a local instance ({workers if workers > 1 else 'all'} CPUs)"
        )
    return "serially in this process" if workers <= 1 else f"{workers} local processes"


def run_items(
    fn, items: list, workers: int = 1, use_ray: bool = False, on_result=None, progress: bool = True, desc: str = "items"
) -> list:
    """fn(item) for every item, serially, on `workers` local processes or as Ray tasks; results in order."""
    items = list(items)
    if workers < 1:
        raise DomainError("--workers", f"must be at least 1, not {workers}")
    results: list = [None] * len(items)
    if not items:
        return results
    bar = tqdm(total=len(items), desc=desc, unit="item", disable=not progress)

    def done(i, result, meta):
        results[i] = result
        if on_result is not None:
            on_result(i, result, meta)
        bar.update(1)

    try:
        if use_ray:
            _run_ray(fn, items, workers, done, desc)
        elif workers == 1:
            one_thread()
            for i, item in enumerate(items):
                t0 = time.perf_counter()
                r = fn(item)
                done(
                    i,
                    r,
                    {"host": socket.gethostname(), "pid": os.getpid(), "seconds": round(time.perf_counter() - t0, 3)},
                )
        else:
            _run_pool(fn, items, workers, done, desc)
    finally:
        bar.close()
    return results


def worker_died(where: str, desc: str, finished: int, total: int, cause: str) -> DomainError:
    """The one-line error of a worker that died mid-run: how many items finished (and were kept by
    on_result) and that a rerun plays the rest."""
    return DomainError(
        where,
        f"a worker process died ({cause}); {finished} of the {total} {desc} finished and "
        "were kept: rerun the command to play the rest",
    )


def _run_pool(fn, items, workers, done, desc: str = "items") -> None:
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    ctx = mp.get_context("spawn")  # no fork of a parent holding torch or a thread pool
    with ProcessPoolExecutor(
        max_workers=min(workers, len(items)), mp_context=ctx, initializer=_worker_init, initargs=(os.getcwd(),)
    ) as pool:
        futures: dict = {}
        taken: set = set()
        try:
            for i, item in enumerate(items):
                futures[pool.submit(_call, fn, item)] = i
            pending = set(futures)
            while pending:
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                for f in sorted(finished, key=futures.get):
                    result, meta = f.result()
                    taken.add(f)
                    done(futures[f], result, meta)
        except BrokenProcessPool:
            # Every item still running failed with the dead worker; those that finished before are kept.
            for f in sorted(futures, key=futures.get):
                if f not in taken and f.done() and not f.cancelled() and f.exception() is None:
                    taken.add(f)
                    done(futures[f], *f.result())
            raise worker_died(
                f"--workers {workers}", desc, len(taken), len(items), "killed, or out of memory"
            ) from None
        except BaseException:
            for f in futures:
                f.cancel()
            raise


def ray_init(workers: int = 1) -> bool:
    """Start or join Ray (RAY_ADDRESS names a cluster); True if this call started it.

    A local instance is kept on the loopback address (Ray's single-machine mode), so it talks
    to nothing but this machine.
    """
    if not os.environ.get("RAY_ADDRESS") and "ray" not in sys.modules:
        os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
    try:
        import ray
    except ImportError:
        raise DomainError("--ray", "Ray is not installed: pip install -e '.[ray]'") from None
    if ray.is_initialized():
        return False
    common = {"include_dashboard": False, "logging_level": "ERROR", "log_to_driver": False}
    address = os.environ.get("RAY_ADDRESS")
    if address:
        ray.init(address=address, runtime_env={"working_dir": os.getcwd(), "excludes": RAY_EXCLUDES}, **common)
    else:
        ray.init(address="local", num_cpus=workers if workers > 1 else None, object_store_memory=256 * 2**20, **common)
    return True


def _run_ray(fn, items, workers, done, desc: str = "items") -> None:
    import ray

    started = ray_init(workers)
    died = tuple(
        getattr(ray.exceptions, name)
        for name in ("WorkerCrashedError", "NodeDiedError", "OutOfMemoryError", "LocalRayletDiedError")
        if hasattr(ray.exceptions, name)
    )
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(_call)
        cwd = os.getcwd()
        refs = {task.remote(fn, item, cwd): i for i, item in enumerate(items)}
        pending = list(refs)
        finished = 0
        try:
            while pending:
                ready, pending = ray.wait(pending, num_returns=1)
                try:
                    result, meta = ray.get(ready[0])
                except died as e:
                    ready, pending = ray.wait(pending, num_returns=len(pending), timeout=0) if pending else ([], [])
                    for ref in ready:  # those done meanwhile are kept too
                        try:
                            done(refs[ref], *ray.get(ref))
                            finished += 1
                        except ray.exceptions.RayError:
                            pass
                    raise worker_died("--ray", desc, finished, len(items), type(e).__name__) from None
                except ray.exceptions.RayTaskError as e:
                    cause = getattr(e, "cause", None)
                    raise (cause if isinstance(cause, BaseException) else e) from None
                done(refs[ready[0]], result, meta)
                finished += 1
        except BaseException:
            for ref in pending:
                ray.cancel(ref, force=True)
            raise
    finally:
        if started:
            ray.shutdown()


def provenance() -> dict:
    """Where a results file comes from: the commit of this checkout (if any), the command, the time."""
    import subprocess

    root = Path(__file__).resolve().parents[1]
    try:
        commit = (
            subprocess.run(
                ["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, timeout=10
            ).stdout.strip()
            or None
        )
    except (OSError, subprocess.SubprocessError):
        commit = None
    return {
        "commit": commit,
        "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]),
        "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }


def results_provenance(config: dict, played=(), kept: dict | None = None) -> dict:
    """A results file's `provenance` (SPEC.md): commit, command and date (`provenance`),
    whether tracked code differed from the commit, the UTC date, the machine, the sha256 of the
    checkpoint the configuration names, the sequences this command played (here or on its workers)
    and, per sequence of the file, the run that played it (`sequences`: this one's commit and date
    for the sequences played now, the earlier run's for those kept; `kept` gives those)."""
    import os
    import platform
    import subprocess
    from datetime import datetime, timezone

    from planning.atomic import sha256

    out = provenance()
    if getattr(sys, "orig_argv", None) and "-m" in sys.orig_argv:
        out["command"] = " ".join(["python", *sys.orig_argv[sys.orig_argv.index("-m") :]])
    try:
        changed = subprocess.run(
            [
                "git",
                "status",
                "--porcelain",
                "--untracked-files=no",
                "--",
                "*.py",
                "*.pddl",
                "*.toml",
                ":(exclude)tests",
            ],
            cwd=Path(__file__).resolve().parents[1],
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout.split("\n")
        out["uncommitted_code"] = sorted(line[3:] for line in changed if line.strip())
    except (OSError, subprocess.SubprocessError):
        out["uncommitted_code"] = None
    out["date_utc"] = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    out["machine"] = {
        "host": platform.node(),
        "platform": platform.platform(),
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
    }
    checkpoint = next((v for k in ("checkpoint", "model") if isinstance(v := (config or {}).get(k), str)), None)
    if checkpoint and Path(checkpoint).is_file():
        out["checkpoint"] = checkpoint
        out["checkpoint_sha256"] = sha256(checkpoint)
    out["played_in_this_process"] = sorted(played)
    if kept is not None:
        this = {"commit": out["commit"], "date_utc": out["date_utc"]}
        out["sequences"] = {str(i): dict(kept.get(i) or this) for i in sorted(set(kept) | set(played))}
        for i in played:
            out["sequences"][str(i)] = this
    return out
