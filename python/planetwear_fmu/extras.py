"""The optional parts of the package and what they need: the campaign
runner needs the `dask` extra (Dask's distributed scheduler and tqdm), the
plots the `plot` extra (matplotlib). A command that needs a missing part
says which extra installs it before it starts any work.

Layer 0 with `files` and the package's `__init__`: it imports no module of
the package (only the standard library), so every other module may use it.
"""

from __future__ import annotations

import importlib.util

# Extra of python/pyproject.toml → the top-level modules it provides.
EXTRAS = {
    "dask": ("distributed", "dask", "tqdm"),
    "plot": ("matplotlib",),
}


class MissingExtra(ImportError):
    """A part of the package is used whose extra is not installed."""


def missing(extra):
    """The modules of `extra` that cannot be imported here."""
    return [m for m in EXTRAS[extra] if importlib.util.find_spec(m) is None]


def require(extra, purpose):
    """Raises MissingExtra naming the extra, the missing modules and the
    install command when `extra` is not fully installed."""
    gone = missing(extra)
    if gone:
        raise MissingExtra(
            f"{purpose} needs the '{extra}' extra of planetwear-fmu (missing: {', '.join(gone)}); "
            f"install it with: pip install \"planetwear-fmu[{extra}]\" (or \"./python[{extra}]\" from a "
            "checkout of the repository)")
