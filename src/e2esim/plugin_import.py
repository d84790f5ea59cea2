"""Import plug-in code defensively: a plug-in that raises, calls ``sys.exit`` or hangs while it is imported is
reported by name, and e2esim goes on without it (issue 22, item 11).

The import runs in a watchdog thread (daemon) that the caller waits for at most ``import_timeout_s()`` seconds
(10 s; ``E2ESIM_PLUGIN_TIMEOUT_S`` sets another). Python cannot abandon an import in progress: a plug-in whose
import hangs stays blocked in its thread until the process ends. That thread holds the import locks of the
plug-in's own modules only, so every other module and command works; a plug-in that hangs inside C code without
releasing the interpreter lock would stall the whole process, which no in-process watchdog can prevent
(docs/security.md).
"""

from __future__ import annotations

import os
import threading

from e2esim.errors import E2ESimWarning

PLUGIN_IMPORT_TIMEOUT_S = 10.0
"""How long the import of one plug-in entry point or class may take before e2esim goes on without it."""

TIMEOUT_VARIABLE = "E2ESIM_PLUGIN_TIMEOUT_S"


class PluginWarning(E2ESimWarning):
    """An installed plug-in could not be loaded: its modules are not available, everything else is."""


class PluginImportFailed(Exception):
    """Importing plug-in code raised, exited or did not finish; the message says which and why."""


def import_timeout_s() -> float:
    """``E2ESIM_PLUGIN_TIMEOUT_S`` when it is a positive number of seconds, else ``PLUGIN_IMPORT_TIMEOUT_S``."""
    try:
        value = float(os.environ.get(TIMEOUT_VARIABLE, ""))
    except ValueError:
        return PLUGIN_IMPORT_TIMEOUT_S
    return value if 0.0 < value < float("inf") else PLUGIN_IMPORT_TIMEOUT_S


def guarded_import(load, timeout_s: float | None = None):
    """``load()`` (an import) run in a watchdog thread: its value, or ``PluginImportFailed`` if it raised (any
    exception, ``SystemExit`` included: then the cause of the ``PluginImportFailed``) or did not return within
    ``timeout_s`` (default ``import_timeout_s()``)."""
    timeout_s = import_timeout_s() if timeout_s is None else timeout_s
    outcome: dict = {}

    def target():
        try:
            outcome["value"] = load()
        except BaseException as exc:  # SystemExit, or anything else a plug-in raises at import
            outcome["error"] = exc

    thread = threading.Thread(target=target, name="e2esim-plugin-import", daemon=True)
    thread.start()
    thread.join(timeout_s)
    if thread.is_alive():
        raise PluginImportFailed(f"its import did not finish within {timeout_s:g} s (set {TIMEOUT_VARIABLE} to "
                                 "wait longer)")
    if "error" in outcome:
        exc = outcome["error"]
        if isinstance(exc, SystemExit):
            raise PluginImportFailed(f"it called sys.exit({exc.code!r}) while being imported") from exc
        raise PluginImportFailed(f"its import raised {type(exc).__name__}: {exc}") from exc
    return outcome["value"]
