"""The documents' generated blocks: the lines between ``<!-- NAME: generated ...`` and
``<!-- end of NAME -->``, which tests compare with their generators. The reference tables
moved from the README to docs/ (one file each)."""

from __future__ import annotations

from paths import ROOT

#: The document that holds each generated block.
DOCUMENTS = {'parameters': ROOT / 'docs' / 'parameters.md',
             'topics': ROOT / 'docs' / 'topics.md'}


def generated_block(name: str) -> str:
    """The block ``name`` ('parameters', 'topics') of its document, markers excluded."""
    text = DOCUMENTS[name].read_text(encoding='utf-8')
    start = text.index(f'<!-- {name}: generated')
    return text[text.index('\n', start) + 1:text.index(f'<!-- end of {name} -->')]
