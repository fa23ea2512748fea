"""Loading the repository's scripts (validation/*/run.py, benchmarks/*.py, docs/*.py) in tests.

They are not importable modules (no package), so tests load them from their path. One loader
for every test file and for the scripts themselves (granflow.verification.scripts).
"""
from __future__ import annotations

from pathlib import Path
from types import ModuleType

from granflow.verification import scripts

ROOT = Path(__file__).resolve().parents[1]


def load_script(rel: str, name: str | None = None, *, cached: bool = False) -> ModuleType:
    """Execute ``ROOT/rel`` as a module and return it (:func:`granflow.verification.scripts.load_script`,
    the loader the validation scripts use for each other).

    ``name`` defaults to ``rel`` with ``/`` and ``.`` replaced by ``_``; the module is registered
    in ``sys.modules`` under it (dataclasses resolve annotations there). ``cached=True`` returns
    the module already registered under that name (scripts that are slow to import, or whose
    module-level state the test file shares); otherwise it is executed afresh.
    """
    return scripts.load_script(ROOT / rel, name or rel.replace("/", "_").replace(".", "_"), cached=cached)


def terminal_sigint() -> None:
    """``preexec_fn`` of a child that a Ctrl-C test signals: SIGINT back to its default action and
    unblocked, as a shell starts a foreground command. Both are inherited through fork and exec:
    a suite started in the background of a non-interactive shell (``.ci/run &``) runs with SIGINT
    ignored, and so did every child, whose run then finished undisturbed by the signal
    (``test_ctrl_c_during_run_start_up_exits_130`` and the sweep's Ctrl-C test failed that way in
    two full runs of session 19, and fail so with the parent's SIGINT set to SIG_IGN)."""
    import signal

    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    signal.signal(signal.SIGINT, signal.SIG_DFL)
