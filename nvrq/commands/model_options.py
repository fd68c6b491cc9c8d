"""The model options shared by every command that runs a model (score, calibrate-tau, stability,
proxy): encoder, weights, tau and its config, metrics, batch size, runtime, precision, device and
threads, and the one encoder-and-tau loader. Library functions validate their own arguments and
name the parameter (``batch_size``); commands do not re-check, and ``nvrq``'s entry point reports
such an error as the option (``--batch-size``, :func:`nvrq.cli_types.flags_in_errors`).
The tau itself comes from the library's one rule, :func:`nvrq.metrics.tau_config.require_tau`.

Layer: commands (CLI shell).
"""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

from data_schema.errors import InputError
from nvrq.cli_types import checked_arg, int_arg, number_arg
from nvrq.encoders import get_spec
from nvrq.encoders.runtimes import PRECISIONS, RUNTIMES
from nvrq.metrics.formulas import check_tau

if TYPE_CHECKING:  # the encoder registry imports OpenCV: not for --help
    from nvrq.encoders import EncoderConfig

__all__ = ["check_model_options", "add_model_arguments", "add_encoder_arguments", "prepare_device",
           "encoder_options", "command_tau", "load_encoder_and_tau", "add_runtime_arguments",
           "add_cache_dir_argument"]


def add_model_arguments(p, *, batch_help: str = "crops per forward pass (default 32)") -> None:
    """``--batch-size``, ``--device``, ``--threads``.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    batch_help : str, optional
        The help of ``--batch-size``.
    """
    p.add_argument("--batch-size", type=int_arg(), default=32, help=batch_help)
    p.add_argument("--device", default="cpu", help="torch device, e.g. cpu or cuda (default cpu)")
    p.add_argument("--threads", type=int_arg(), default=None, help="torch CPU threads (default: all cores)")


def add_encoder_arguments(p, *, tau: bool = True) -> None:
    """``--encoder``, ``--weights``, ``--config`` (+ ``--tau``) and :func:`add_model_arguments`.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    tau : bool, optional
        Also add ``--tau``.
    """
    p.add_argument("--encoder", default=None, help=f"encoder for nvrq/nvrq_ca (default {get_spec().name})")
    p.add_argument("--weights", default=None,
                   help="local weights: a Hugging Face model folder, or a .pth for efficientnet-lite0")
    if tau:
        p.add_argument("--tau", type=checked_arg(float, check_tau), default=None,
                       help="NVRQ-CA tau (default: user config, then registry)")
    p.add_argument("--config", default=None,
                   help="tau config file (default $NVRQ_CONFIG or ~/.config/nvrq/tau.json)")
    add_model_arguments(p, batch_help="encoder batch size (default 32)")
    add_runtime_arguments(p)


def add_runtime_arguments(p, *, precision: bool = True) -> None:
    """``--runtime``, ``--precision``, ``--min-spearman``, ``--cache-dir`` (nvrq.encoders.runtimes);
    fp32 models (the proxies' classifiers) take ``precision=False``: no precision options.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    precision : bool, optional
        Also add ``--precision`` and ``--min-spearman``.
    """
    p.add_argument("--runtime", default="auto", choices=RUNTIMES,
                   help="model runtime (default auto: on CPU the fastest exported runtime identical "
                        "to torch fp32, else torch)")
    if precision:
        p.add_argument("--precision", default="fp32", choices=PRECISIONS,
                       help="encoder precision (default fp32; bf16/int8 need `nvrq calibrate-runtime` first)")
        p.add_argument("--min-spearman", type=number_arg(low=-1, high=1), default=None,
                       help="NVRQ Spearman a reduced precision's drift check must reach (default 0.999)")
    add_cache_dir_argument(p)


def add_cache_dir_argument(p) -> None:
    """``--cache-dir``: where exported models and drift checks are kept (nvrq.encoders.runtimes).

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    """
    p.add_argument("--cache-dir", default=None,
                   help="exported-model cache (default $NVRQ_CACHE, else ~/.cache/nvrq)")


def check_model_options(args) -> None:
    """A model command's ``--runtime``/``--precision``/``--device`` combination
    (:func:`nvrq.encoders.runtimes.check_runtime_combo`), before anything is read or loaded.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options.

    Raises
    ------
    InputError
        An unknown or unsupported combination.
    """
    from nvrq.encoders.runtimes import check_runtime_combo

    if hasattr(args, "runtime"):
        check_runtime_combo(args.runtime, getattr(args, "precision", "fp32"), str(getattr(args, "device", "cpu")))


def prepare_device(args) -> None:
    """Apply ``--threads`` and refuse ``--device cuda`` without a GPU (before any model loads);
    keep freed activations in the heap (:func:`nvrq.encoders.memory.tune_allocator`, a
    process-wide setting the commands make and the library leaves to its caller).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options (``threads``, ``device``).

    Raises
    ------
    InputError
        ``--device cuda`` without a GPU.
    """
    import torch

    from nvrq.encoders.memory import tune_allocator

    if getattr(args, "threads", None) is not None:
        torch.set_num_threads(args.threads)  # a positive integer (checked when parsed)
    if str(args.device).startswith("cuda") and not torch.cuda.is_available():
        raise InputError("--device", None, "an available device (cpu, or cuda with a GPU)", args.device)
    tune_allocator()


def command_tau(name: str, args) -> float:
    """The tau of encoder ``name`` for a command with ``--tau``/``--config``
    (:func:`nvrq.metrics.tau_config.require_tau`, before the model loads), reported on stderr with where it
    came from (``--tau``, the config file or the registry).

    Parameters
    ----------
    name : str
        The encoder name.
    args : argparse.Namespace
        The parsed options (``tau``, ``config``).

    Returns
    -------
    float
        tau.
    """
    from nvrq.encoders.registry import get_spec
    from nvrq.metrics.tau_config import require_tau

    tau, source = require_tau(name, tau=args.tau, config=args.config, registry_tau=get_spec(name).tau)
    print(f"tau = {tau:.3f} for {name} (from {'--tau' if source == 'argument' else source})", file=sys.stderr)
    return tau


def encoder_options(args, name: str | None = None) -> EncoderConfig:
    """The :class:`~nvrq.encoders.EncoderConfig` of a command built with
    :func:`add_encoder_arguments`: encoder ``name`` (default ``--encoder``, else the registry
    default) with ``--weights``, ``--device``, ``--runtime``, ``--precision``, ``--threads``,
    ``--cache-dir`` and ``--min-spearman``.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options.
    name : str, optional
        The encoder (default ``args.encoder``).

    Returns
    -------
    EncoderConfig
    """
    from nvrq.encoders import EncoderConfig

    name = get_spec(name or args.encoder).name
    return EncoderConfig(name, weights=args.weights, device=args.device, runtime=args.runtime,
                         precision=args.precision, threads=args.threads, cache_dir=args.cache_dir,
                         min_spearman=args.min_spearman)


def load_encoder_and_tau(args, *, needs_tau: bool, name: str | None = None):
    """``(encoder, tau)`` for a command built with :func:`add_encoder_arguments`: the encoder of
    :func:`encoder_options`; ``tau`` from ``--tau``, the config (``--config``) or the registry
    when ``needs_tau``, else ``None``.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options.
    needs_tau : bool
        Whether a metric needs tau.
    name : str, optional
        The encoder (default ``args.encoder``).

    Returns
    -------
    encoder : Encoder
    tau : float or None
    """
    from nvrq import encoders

    cfg = encoder_options(args, name)
    tau = command_tau(cfg.name, args) if needs_tau else None
    prepare_device(args)
    encoder = encoders.load_encoder(cfg)  # through the module: tests patch nvrq.encoders.load_encoder
    return encoder, tau
