"""A griffe extension for the API reference (mkdocs.yml): the package's docstrings use reST roles
(``:class:`~modquad_gym.Structure```), which Markdown would print as they are; here they become
inline code naming the object."""

from __future__ import annotations

import re

import griffe

_ROLE = re.compile(r":(?:class|func|meth|mod|attr|data|obj|exc|ref):`~?([^`]+)`")


class RstRoles(griffe.Extension):
    """Rewrite reST roles in every docstring to inline code (``~`` keeps the last name)."""

    def on_instance(self, *, obj, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = _ROLE.sub(_code, obj.docstring.value)


def _code(match: re.Match) -> str:
    name = match.group(1)
    return f"`{name.split('.')[-1] if match.group(0).count('~') else name}`"
