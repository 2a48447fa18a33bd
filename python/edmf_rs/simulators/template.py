"""Input-deck templates: ``{NAME}`` placeholders replaced by one instance's parameters.

A placeholder is ``{NAME}`` where NAME is a parameter's name, exactly as written
in the project file (spaces and non-ASCII letters included: ``{E mod}``,
``{é}``), or any other identifier (Unicode letters, digits, ``_``; refused as
naming no parameter). Other braces (JSON, shell) are kept; ``{{`` and ``}}``
write a literal brace. A parameter name that is empty or has a brace cannot be
a placeholder unambiguously and is refused (:func:`check_names`). Values
are written with ``repr(float(value))``: the shortest text that reads back as
the same float64, so the solver sees exactly the sampled parameter.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from functools import lru_cache

_IDENTIFIER = r"[^\W\d]\w*"  # a (Unicode) identifier: a letter or _, then letters, digits, _


@lru_cache(maxsize=64)
def _token(names: tuple[str, ...]) -> re.Pattern:
    """``{{``, ``}}``, or ``{NAME}`` (group 1) with NAME one of ``names`` or an identifier."""
    exact = "".join(re.escape(n) + "|" for n in sorted(set(names), key=len, reverse=True) if n)
    return re.compile(r"\{\{|\}\}|\{(" + exact + _IDENTIFIER + r")\}")


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


def check_names(parameters: Iterable[str]) -> None:
    """Raises :class:`TemplateError` for a parameter name no placeholder can name
    unambiguously (empty, or with ``{`` or ``}``).

    Examples
    --------
    >>> check_names(["E mod", "é"])
    >>> check_names(["a}b"])
    Traceback (most recent call last):
    ...
    edmf_rs.simulators.template.TemplateError: command: parameter 'a}b' cannot be named by a placeholder: {NAME} takes any parameter name except an empty one or one with '{' or '}'; rename the parameter
    """
    for name in parameters:
        if not name or "{" in name or "}" in name:
            raise TemplateError(f"command: parameter {name!r} cannot be named by a placeholder: {{NAME}} takes any "
                                "parameter name except an empty one or one with '{' or '}'; rename the parameter")


def placeholders(text: str, parameters: Iterable[str] = ()) -> list[str]:
    """The placeholder names of ``text`` in order of first appearance: the
    ``parameters`` it names and any other ``{identifier}``.

    Examples
    --------
    >>> placeholders("*MATERIAL\\n*ELASTIC\\n{E}, 0.2\\n{{not}} {K_rot} {E}")
    ['E', 'K_rot']
    >>> placeholders("{E mod} {é} {x y}", ["E mod"])
    ['E mod', 'é']
    """
    seen: dict[str, None] = {}
    for m in _token(tuple(parameters)).finditer(text):
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
    for name in placeholders(text, names):
        if name not in names:
            raise TemplateError(f"{where}: placeholder {{{name}}} names no parameter "
                                f"(the parameters are: {', '.join(names)})")


def render(text: str, values: Mapping[str, float]) -> str:
    """``text`` with every ``{NAME}`` replaced by ``repr(float(values[NAME]))``.

    Examples
    --------
    >>> render("E = {E} {{E}}", {"E": 0.1 + 0.2})
    'E = 0.30000000000000004 {E}'
    >>> render("{E mod} {é}", {"E mod": 2.0, "é": 3.0})
    '2.0 3.0'
    """
    def sub(m: re.Match) -> str:
        if m.group(1) is None:
            return m.group(0)[0]
        return repr(float(values[m.group(1)]))

    return _token(tuple(values)).sub(sub, text)
