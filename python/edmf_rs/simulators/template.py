"""Input-deck templates: ``{NAME}`` placeholders replaced by one instance's parameters.

Only ``{identifier}`` is a placeholder, so decks that use braces for other
things (JSON, shell) keep them; ``{{`` and ``}}`` write a literal brace. Values
are written with ``repr(float(value))``: the shortest text that reads back as
the same float64, so the solver sees exactly the sampled parameter.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping

_TOKEN = re.compile(r"\{\{|\}\}|\{([A-Za-z_][A-Za-z0-9_]*)\}")


class TemplateError(ValueError):
    """A template naming a placeholder that is not a parameter (a ``ValueError``).

    Attributes
    ----------
    args : tuple of str
        The message, naming the template file and the placeholder.

    Examples
    --------
    >>> issubclass(TemplateError, ValueError)
    True
    """


def placeholders(text: str) -> list[str]:
    """The placeholder names of ``text`` in order of first appearance.

    Examples
    --------
    >>> placeholders("*MATERIAL\\n*ELASTIC\\n{E}, 0.2\\n{{not}} {K_rot} {E}")
    ['E', 'K_rot']
    """
    seen: dict[str, None] = {}
    for m in _TOKEN.finditer(text):
        if m.group(1):
            seen.setdefault(m.group(1))
    return list(seen)


def check_placeholders(text: str, parameters: Iterable[str], where: str) -> None:
    """Raises :class:`TemplateError` naming ``where`` and the first unknown placeholder.

    Examples
    --------
    >>> check_placeholders("{E} {K}", ["E"], "girder.inp")
    Traceback (most recent call last):
    ...
    edmf_rs.simulators.template.TemplateError: girder.inp: placeholder {K} names no parameter (the parameters are: E)
    """
    names = list(parameters)
    for name in placeholders(text):
        if name not in names:
            raise TemplateError(f"{where}: placeholder {{{name}}} names no parameter "
                                f"(the parameters are: {', '.join(names)})")


def render(text: str, values: Mapping[str, float]) -> str:
    """``text`` with every ``{NAME}`` replaced by ``repr(float(values[NAME]))``.

    Examples
    --------
    >>> render("E = {E} {{E}}", {"E": 0.1 + 0.2})
    'E = 0.30000000000000004 {E}'
    """
    def sub(m: re.Match) -> str:
        if m.group(1) is None:
            return m.group(0)[0]
        return repr(float(values[m.group(1)]))

    return _TOKEN.sub(sub, text)
