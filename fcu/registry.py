"""A name -> factory table for each pluggable kind of autopilot part, tied to the vocabulary.

The autopilot's configuration chooses its parts by name (``attitude = "lqg"``,
``estimator = "tskf"``...). The names and their order are defined once, in
:mod:`flightdata.vocabulary` (the index of a name is the value of the MAVLink parameter that
selects it); each kind of part has one :class:`Registry` that maps every one of those names
to the factory building the part. A registry checks when it is created, that is when its
module is imported, that its names are exactly the vocabulary's: a name in one and not in
the other fails at import, not at the first flight that asks for it.

The registries themselves live next to the parts they build:

* :mod:`fcu.estimation.registry`: state estimators (``ESTIMATORS``);
* :mod:`fcu.control.registry`: attitude laws (``ATTITUDE_LAWS``), disturbance observers
  (``DISTURBANCE_OBSERVERS``) and control allocators (``ALLOCATORS``).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from types import MappingProxyType
from typing import Generic, TypeVar

F = TypeVar("F")


class RegistryError(ValueError):
    """A registry's names and the vocabulary's differ (a programming error, at import)."""


class Registry(Generic[F]):
    """The factories of one kind of part, one per vocabulary name, in vocabulary order.

    Parameters
    ----------
    kind : str
        What the parts are (``"attitude law"``), for messages.
    key : str
        The configuration key that selects one (``"attitude"``), for messages.
    vocabulary : tuple of str
        The names of :mod:`flightdata.vocabulary` for this kind, in parameter-value order.
    factories : mapping of str to factory
        One factory per name; their call signature is the kind's (see its registry module).

    Raises
    ------
    RegistryError
        When a vocabulary name has no factory or a factory's name is not in the vocabulary.
    """

    def __init__(self, kind: str, key: str, vocabulary: tuple[str, ...],
                 factories: Mapping[str, F]) -> None:
        missing = [name for name in vocabulary if name not in factories]
        extra = [name for name in factories if name not in vocabulary]
        if missing or extra or len(set(vocabulary)) != len(vocabulary):
            problems = []
            if missing:
                problems.append(f"no factory for {', '.join(map(repr, missing))}")
            if extra:
                problems.append(f"{', '.join(map(repr, extra))} not in the vocabulary")
            if len(set(vocabulary)) != len(vocabulary):
                problems.append("the vocabulary repeats a name")
            raise RegistryError(f"{kind} registry ({key}) does not match "
                                f"flightdata.vocabulary {vocabulary!r}: {'; '.join(problems)}")
        self.kind = kind
        self.key = key
        self._factories: Mapping[str, F] = MappingProxyType(
            {name: factories[name] for name in vocabulary})

    @property
    def names(self) -> tuple[str, ...]:
        """The registered names, in vocabulary (parameter-value) order."""
        return tuple(self._factories)

    def __contains__(self, name: object) -> bool:
        return name in self._factories

    def __iter__(self) -> Iterator[str]:
        return iter(self._factories)

    def __len__(self) -> int:
        return len(self._factories)

    def factory(self, name: str) -> F:
        """The factory registered under ``name``.

        Raises
        ------
        ValueError
            ``name`` is not registered; the message names the key and the choices.
        """
        try:
            return self._factories[name]
        except (KeyError, TypeError):
            raise ValueError(f"{self.key} = {name!r}: must be one of "
                             f"{', '.join(map(repr, self._factories))}") from None

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, {self.key!r}, {self.names!r})"
