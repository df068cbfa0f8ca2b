"""numba's vector width for every station kernel, set before numba makes its first dispatcher.

LLVM tunes the x86 CPUs with AVX-512 (Skylake-X and later) to prefer 256-bit vectors
(the ``prefer-256-bit`` tuning), so numba's column loops use half of the registers'
width. Without that tuning (``-prefer-256-bit`` after the host's features) the cpu
backend's sweeps run on 512-bit vectors: -6 % sweep time at 1920x1080 (session 14),
the same bits (the kernels are element-wise IEEE float32 maths without fastmath: no
reassociated sum, no contracted multiply-add, whatever the width; the bitwise tests
hold numpy == cpu under it).

numba fixes its target machine's features once, when the first dispatcher of a process
is created (any ``@njit`` decorator, at import), so setting ``numba.core.config`` in the
cpu backend's package came too late whenever another numba user was imported first (the
kiosk's display, the brush, the tests' conftest). ``station/__init__`` calls
:func:`install`, which every station module passes through before its own ``import
numba``; it does not import numba itself (0.6 s that most commands never pay) but hooks
numba's import: :func:`configure` runs right after numba's package is executed, before
the importing module creates its dispatchers.

Left as they are: machines without ``avx512f`` (features as numba chooses them), a
process whose ``NUMBA_CPU_FEATURES`` / ``NUMBA_CPU_NAME`` says what it wants, one with
``STATION_WIDE_VECTORS=0`` (LLVM's tuning, for comparisons), and one where numba made a
dispatcher before station was imported (too late: :func:`active` then says so). numba's
on-disk cache is keyed by the features, so kernels cached under either width stay
valid; child processes decide for themselves (an older tree under ``station bench sim
--baseline`` keeps LLVM's tuning).
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import os
import sys
from collections.abc import Callable, Sequence
from types import ModuleType

WIDE = "-prefer-256-bit"
"""Appended to the host's features: LLVM's x86 tuning flag that caps the vectoriser at
256 bits on AVX-512 CPUs."""

ENV_OFF = "STATION_WIDE_VECTORS"
"""``0`` keeps LLVM's own tuning (256-bit vectors on AVX-512 CPUs)."""


def wide_features(host: str) -> str | None:
    """The feature string for 512-bit vectors from the host's (LLVM's ``+a,-b,...``
    form), or None where the host has no AVX-512 (nothing to widen)."""
    flags = host.split(",")
    if "+avx512f" not in flags or WIDE in flags:
        return None
    return f"{host},{WIDE}"


def _too_late() -> bool:
    """numba's CPU target has made its target context: its features are fixed."""
    from numba.core import registry

    return "_toplevel_target_context" in vars(registry.cpu_target)


def configure() -> bool:
    """Set numba's CPU features for 512-bit vectors if this process may still choose
    them; True when set (also when they already were)."""
    from numba.core import codegen, config

    if os.environ.get(ENV_OFF, "1") == "0":
        return False
    # numba's config sets its variables from the environment at run time (getattr: no
    # declarations for a type checker)
    have = getattr(config, "CPU_FEATURES", None)
    if have is not None or getattr(config, "CPU_NAME", None) is not None:
        return WIDE in str(have).split(",")
    if _too_late():
        return False
    host: Callable[[], str] = codegen.get_host_cpu_features  # honours NUMBA_ENABLE_AVX
    feats = wide_features(host())
    if feats is None:
        return False
    config.CPU_FEATURES = feats  # type: ignore[attr-defined]
    return True


def active() -> bool:
    """numba's CPU target in this process compiles for 512-bit vectors (makes the
    target context if none is made yet)."""
    from numba.core import registry

    feats: str = registry.cpu_target.target_context.codegen()._tm_features
    return WIDE in feats.split(",")


class _AfterNumba(importlib.abc.MetaPathFinder):
    """Finds numba's package as the path finder does and runs :func:`configure` right
    after the package has executed; it leaves ``sys.meta_path`` when numba is imported,
    not when numba is only looked for (``importlib.util.find_spec("numba")``, as
    ``backends.factory.numba_available`` does before any import)."""

    def find_spec(self, fullname: str, path: Sequence[str] | None,
                  target: ModuleType | None = None) -> importlib.machinery.ModuleSpec | None:
        if fullname != "numba":
            return None
        spec = importlib.machinery.PathFinder.find_spec(fullname, path)
        loader = spec.loader if spec is not None else None
        if loader is None or not hasattr(loader, "exec_module"):
            return spec
        run = loader.exec_module

        def exec_module(module: ModuleType) -> None:
            if self in sys.meta_path:
                sys.meta_path.remove(self)
            run(module)
            configure()

        loader.exec_module = exec_module  # type: ignore[method-assign]
        return spec


def install() -> None:
    """Arrange for :func:`configure` to run before numba's first dispatcher: at once if
    numba is imported already, else right after its import."""
    if "numba" in sys.modules:
        configure()
    elif not any(isinstance(f, _AfterNumba) for f in sys.meta_path):
        sys.meta_path.insert(0, _AfterNumba())
