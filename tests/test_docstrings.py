"""Every public parameter is documented (in the spirit of python-control's ``docstrings_test``).

For each name a module of ``rths``, ``plants`` or ``controllers`` exports in ``__all__`` and
defines itself: a function's parameters must appear in its numpydoc ``Parameters`` section; a
class's constructor parameters in the class's (or ``__init__``'s) ``Parameters``/``Attributes``
section -- a dataclass's fields count as its constructor's.  Names may be grouped
(``a3_std, beta1_std``).  Keyword catch-alls (``**options``) must be documented too;
``self``/``cls``, names starting with ``_`` and private modules (``_name``) are exempt.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re

import pytest

PACKAGES = ("rths", "plants", "controllers")


def _modules() -> list[str]:
    names = []
    for root in PACKAGES:
        package = importlib.import_module(root)
        names.append(root)
        names += [
            m.name
            for m in pkgutil.walk_packages(package.__path__, prefix=f"{root}.")
            if not m.name.endswith("__main__")
            and not any(part.startswith("_") for part in m.name.split("."))
        ]
    return sorted(names)


def _documented(doc: str) -> set[str]:
    """Names listed in the Parameters/Attributes/Other Parameters sections of a docstring."""
    found: set[str] = set()
    lines = inspect.cleandoc(doc or "").splitlines()
    in_section = False
    for i, line in enumerate(lines):
        nxt = lines[i + 1] if i + 1 < len(lines) else ""
        if re.fullmatch(r"-{3,}", nxt.strip()):
            in_section = line.strip() in ("Parameters", "Attributes", "Other Parameters")
            continue
        if in_section and line and not line.startswith(" ") and not re.fullmatch(r"-{3,}", line):
            head = line.split(" : ")[0]
            found |= {n.strip().lstrip("*") for n in head.split(",")}
    return found


def _parameters(func: object) -> list[str]:
    try:
        sig = inspect.signature(func)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return []
    return [p for p in sig.parameters if p not in ("self", "cls") and not p.startswith("_")]


def _undocumented(module_name: str) -> list[str]:
    module = importlib.import_module(module_name)
    missing = []
    for name in getattr(module, "__all__", ()):
        obj = getattr(module, name, None)
        if getattr(obj, "__module__", None) != module_name:
            continue  # re-exported: checked where it is defined
        if inspect.isclass(obj):
            if getattr(obj, "_is_protocol", False):
                continue  # a Protocol is not instantiated: its signature is a placeholder
            # an inherited field (a dataclass's base) is documented where it is declared
            docs = set().union(*(_documented(c.__doc__ or "") for c in obj.__mro__[:-1]))
            init = obj.__dict__.get("__init__")
            if init is not None:
                docs |= _documented(init.__doc__ or "")
            params = _parameters(obj)
        elif inspect.isfunction(obj):
            docs, params = _documented(obj.__doc__ or ""), _parameters(obj)
        else:
            continue
        missing += [f"{module_name}.{name}({p})" for p in params if p not in docs]
    return missing


@pytest.mark.parametrize("module_name", _modules())
def test_every_public_parameter_is_documented(module_name):
    assert _undocumented(module_name) == []
