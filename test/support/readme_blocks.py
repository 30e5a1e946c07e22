"""The README's generated blocks: the lines between ``<!-- NAME: generated ...`` and
``<!-- end of NAME -->``, which tests compare with their generators."""

from __future__ import annotations

from paths import ROOT

README = ROOT / 'README.md'


def generated_block(name: str) -> str:
    """The README's block ``name`` ('parameters', 'topics'), markers excluded."""
    readme = README.read_text(encoding='utf-8')
    start = readme.index(f'<!-- {name}: generated')
    return readme[readme.index('\n', start) + 1:readme.index(f'<!-- end of {name} -->')]
