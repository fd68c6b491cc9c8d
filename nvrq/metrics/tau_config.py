"""The tau config: the small user file that stores calibrated taus, and the one tau rule.

Metrics layer, a leaf: it imports :mod:`data_schema` and :mod:`nvrq.metrics.formulas` only, so
the scoring plan, the commands and :mod:`nvrq.calibrate` (which measures a tau and writes it
here) all share it without an import running back up.

Config file (JSON ``{"ENCODER": {"tau": 0.61, ...}}``), first found of: the ``config``
argument, ``$NVRQ_CONFIG``, ``$XDG_CONFIG_HOME/nvrq/tau.json``, ``~/.config/nvrq/tau.json``.
The one tau rule, :func:`require_tau`: the ``tau`` given, else this file's, else the encoder
registry's (``nvrq score`` and the Python API both ask it; the value is checked by
:func:`nvrq.metrics.formulas.check_tau`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from data_schema.errors import InputError
from nvrq.metrics.formulas import check_tau

__all__ = ["config_path", "read_tau_config", "write_tau", "require_tau"]


def config_path(config: str | os.PathLike | None = None) -> Path:
    """The tau config file in use (it need not exist yet).

    Parameters
    ----------
    config : str or PathLike, optional
        An explicit file; else ``$NVRQ_CONFIG``, else ``$XDG_CONFIG_HOME/nvrq/tau.json``
        (``~/.config`` by default).

    Returns
    -------
    Path
    """
    if config is not None:
        return Path(config)
    if os.environ.get("NVRQ_CONFIG"):
        return Path(os.environ["NVRQ_CONFIG"])
    base = os.environ.get("XDG_CONFIG_HOME") or os.path.join(Path.home(), ".config")
    return Path(base) / "nvrq" / "tau.json"


def read_tau_config(path: str | os.PathLike) -> dict:
    """The config's content (``{}`` if the file does not exist).

    Parameters
    ----------
    path : str or PathLike
        The config file.

    Returns
    -------
    dict
        ``{encoder: {'tau': float, ...}}``.
    """
    path = Path(path)
    if not path.is_file():
        return {}
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise InputError(path, None, "a JSON tau config", f"{type(exc).__name__}: {exc}") from None
    if not isinstance(data, dict):
        raise InputError(path, None, 'a JSON object {"ENCODER": {"tau": ...}}', type(data).__name__)
    return data


def write_tau(path: str | os.PathLike, encoder: str, tau: float, **info) -> Path:
    """Store ``tau`` (and ``info``) for ``encoder`` in the config, keeping other entries.

    Parameters
    ----------
    path : str or PathLike
        The config file (created with its folder).
    encoder : str
        The encoder name.
    tau : float
        The calibrated tau.
    **info
        More fields stored with it (e.g. counts, the pairs file).

    Returns
    -------
    Path
        ``path``.
    """
    from data_schema.tables import atomic_write_text  # pandas: not for reading a tau

    path = Path(path)
    data = read_tau_config(path)
    data[encoder] = {"tau": float(tau), **info}
    atomic_write_text(path, json.dumps(data, indent=2, sort_keys=True) + "\n")
    return path


def require_tau(encoder: str, *, tau: float | None = None, config: str | os.PathLike | None = None,
                registry_tau: float | None = None) -> tuple[float, str]:
    """The NVRQ-CA knee for ``encoder``, by the one tau rule: ``tau`` > user config > registry.

    Parameters
    ----------
    encoder : str
        The encoder name (the config file's key).
    tau : float, optional
        A tau given by the caller; it wins.
    config : path, optional
        The tau config file (default :func:`config_path`'s).
    registry_tau : float, optional
        The encoder registry's tau for ``encoder`` (``EncoderSpec.tau``; the caller reads it, so
        this module imports nothing above the metrics), used when neither of the others is.

    Returns
    -------
    tuple of (float, str)
        ``(tau, source)``: ``source`` is ``'argument'`` (the ``tau`` given), the config file's
        path, or ``'registry'``.

    Raises
    ------
    InputError
        Naming ``tau`` when the value found is not in (0, 1) (:func:`check_tau`; the config file
        and its key for a config value), or when there is none.

    >>> require_tau("enc", tau=0.5)
    (0.5, 'argument')
    """
    if tau is not None:
        check_tau(tau)
        return float(tau), "argument"
    path = config_path(config)
    entry = read_tau_config(path).get(encoder)
    if entry is not None:
        value = entry.get("tau") if isinstance(entry, dict) else None
        check_tau(value, where=path, field=f"{encoder}.tau")
        return float(value), str(path)
    if registry_tau is None:
        raise InputError(param="tau", expected=f"a tau for encoder {encoder} (`nvrq calibrate-tau` measures one "
                         "and can store it in the user config)", got="none in the registry or the user config")
    check_tau(registry_tau)
    return float(registry_tau), "registry"
