"""One registry per family of kinds, filled by a decorator on the class (nengo's
``@Builder.register`` is the model).

A scenario file names each component by its ``kind`` (``[specimen] kind = "imd"``).  The class
that implements a kind registers itself where it is defined, with the frozen dataclass of its
options::

    @dataclass(frozen=True)
    class ViscousOptions:
        \"\"\"Parameters
        ----------
        damping
            Viscous coefficient c [N s/m], > 0.
        \"\"\"
        damping: float

    @SPECIMENS.register("viscous", ViscousOptions)
    class ViscousDamper(Specimen):
        @classmethod
        def from_options(cls, options: ViscousOptions, **context: object) -> ViscousDamper:
            return cls(options.damping)

Scenario validation, building, the fully numerical run, ``rths kinds``, ``rths run --help`` and
the README's table of kinds all read these registries, so adding a damper model is one new module
(with its tests) and nothing else: :func:`rths.config.kinds.load_kinds` imports every module of
``plants`` and ``controllers`` (and the modules of the ``rths.kinds`` entry-point group) so that
their decorators run.

What ``from_options`` receives besides the options (keyword arguments; a factory takes those it
needs and ``**context`` for the rest):

=============  ===========================================================================
family         context
=============  ===========================================================================
substructure   ``dt`` [s], ``device`` (the nominal interface device or None)
specimen       ``rng`` (a :class:`numpy.random.Generator` for a Monte-Carlo draw, or None)
actuator       ``specimen``, ``dt`` [s], ``rng``
compensator    ``dt`` [s], ``nominal`` (python-control model), ``delay`` [s]
=============  ===========================================================================

Kinds that are functions rather than classes (a factory choosing between classes) register the
same way: the decorated function is the factory.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, TypeVar

from rths.core.errors import ParameterError, format_choices

__all__ = [
    "ACTUATORS",
    "COMPENSATORS",
    "FAMILIES",
    "SPECIMENS",
    "SUBSTRUCTURES",
    "Kind",
    "NoOptions",
    "Registry",
    "first_sentence",
]

T = TypeVar("T")

_NAME = re.compile(r"^[a-z][a-z0-9_]*$")


@dataclass(frozen=True)
class NoOptions:
    """A kind without options."""


@dataclass(frozen=True)
class Kind:
    """One registered kind.

    Attributes
    ----------
    family
        ``"substructure"``, ``"specimen"``, ``"actuator"`` or ``"compensator"``.
    name
        The ``kind`` scenario files use.
    options
        Frozen dataclass of the kind's options (validated by the scenario parser).
    factory
        Builds the component: ``factory(options, **context)`` (see the module docstring).
    target
        The registered class (or factory function).
    """

    family: str
    name: str
    options: type
    factory: Callable[..., Any]
    target: Any

    @property
    def summary(self) -> str:
        """First sentence of the registered target's docstring."""
        paragraph = (self.target.__doc__ or "").strip().split("\n\n")[0]
        return first_sentence(" ".join(paragraph.split()))

    @property
    def module(self) -> str:
        """Module that defines the kind."""
        return str(self.target.__module__)

    def build(self, options: Any, **context: Any) -> Any:
        """Build the component from validated ``options`` and the family's context."""
        if not isinstance(options, self.options):
            raise ParameterError(
                f"{self.family} kind {self.name!r} takes {self.options.__name__} options; got "
                f"{type(options).__name__}"
            )
        return self.factory(options, **context)


class Registry:
    """The kinds of one family, keyed by name (see the module docstring).

    Parameters
    ----------
    family
        Name of the family, used in messages and by ``rths kinds``.
    """

    def __init__(self, family: str) -> None:
        self.family = family
        self._kinds: dict[str, Kind] = {}

    def register(self, name: str, options: type | None = None) -> Callable[[T], T]:
        """Class (or factory-function) decorator registering ``name`` with its ``options``.

        A class must define a classmethod ``from_options(options, **context)``; its ``kind``
        class attribute is set to ``name`` so the two can never drift.

        Raises
        ------
        ValueError
            If ``name`` is malformed or already registered to another target, or ``options``
            is not a frozen dataclass.
        TypeError
            If a class has no ``from_options``.
        """
        if not isinstance(name, str) or not _NAME.match(name):
            raise ValueError(f"{self.family} kind must match [a-z][a-z0-9_]*; got {name!r}")
        opts = NoOptions if options is None else options
        if not (dataclasses.is_dataclass(opts) and isinstance(opts, type)):
            raise ValueError(f"options of {self.family} kind {name!r} must be a dataclass type")
        if not opts.__dataclass_params__.frozen:  # type: ignore[attr-defined]
            raise ValueError(f"options of {self.family} kind {name!r} must be a frozen dataclass")

        def decorate(target: T) -> T:
            if isinstance(target, type):
                factory = getattr(target, "from_options", None)
                if not callable(factory):
                    raise TypeError(
                        f"{target.__name__} registered as {self.family} kind {name!r} needs a "
                        f"classmethod from_options(options, **context)"
                    )
                target.kind = name  # type: ignore[attr-defined]
            elif callable(target):
                factory = target
            else:
                raise TypeError(f"cannot register {target!r} as {self.family} kind {name!r}")
            old = self._kinds.get(name)
            if old is not None and _qualname(old.target) != _qualname(target):
                raise ValueError(
                    f"{self.family} kind {name!r} is already registered by {_qualname(old.target)}"
                )
            self._kinds[name] = Kind(self.family, name, opts, factory, target)
            return target

        return decorate

    def unregister(self, name: str) -> None:
        """Forget ``name`` (for tests that register a temporary kind); unknown names are ignored."""
        self._kinds.pop(name, None)

    def get(self, name: str) -> Kind:
        """The kind called ``name``; :class:`ParameterError` listing the choices otherwise."""
        try:
            return self._kinds[name]
        except (KeyError, TypeError):
            raise ParameterError(
                f"unknown {self.family} kind {name!r}; choose one of {format_choices(self.names())}"
            ) from None

    def names(self) -> tuple[str, ...]:
        """Registered names, sorted."""
        return tuple(sorted(self._kinds))

    def __contains__(self, name: object) -> bool:
        return name in self._kinds

    def __iter__(self) -> Iterator[Kind]:
        return iter(self._kinds[name] for name in self.names())

    def __len__(self) -> int:
        return len(self._kinds)


def first_sentence(text: str) -> str:
    """``text`` up to the first full stop that ends a sentence.

    A full stop ends a sentence when it ends ``text`` or is followed by white space and a capital
    letter or ``(``; so ``"e.g. the"`` and ``"1.5 m"`` do not end one.

    Parameters
    ----------
    text : str
        One paragraph, white space already collapsed (e.g. a docstring's first paragraph).
    """
    match = re.search(r"\.(?=\s+[A-Z(]|$)", text)
    return text if match is None else text[: match.end()]


def _qualname(target: Any) -> str:
    return f"{target.__module__}.{target.__qualname__}"


#: Numerical substructures (``[substructure]``).
SUBSTRUCTURES = Registry("substructure")
#: Physical specimens of the emulated lab (``[specimen]``).
SPECIMENS = Registry("specimen")
#: Transfer systems driving the specimen (``[actuator]``).
ACTUATORS = Registry("actuator")
#: Compensators (``[compensator]``).
COMPENSATORS = Registry("compensator")

#: The four families, in the order of a scenario file.
FAMILIES: dict[str, Registry] = {
    r.family: r for r in (SUBSTRUCTURES, SPECIMENS, ACTUATORS, COMPENSATORS)
}
