"""``python -m screwgear_ros.params.docs --write`` rewrites config/paper.yaml and the
parameter table of docs/parameters.md in place, and touches nothing else of either file."""

from __future__ import annotations

import shutil
from pathlib import Path

from paths import ROOT

from screwgear_ros.params import docs


def _tree(root: Path) -> Path:
    (root / 'config').mkdir(parents=True)
    (root / 'docs').mkdir()
    shutil.copy(ROOT / docs.TABLE_DOCUMENT, root / docs.TABLE_DOCUMENT)
    shutil.copy(ROOT / 'config' / 'paper.yaml', root / 'config' / 'paper.yaml')
    return root


def test_write_rewrites_a_stale_table_and_file_in_place(tmp_path, capsys):
    root = _tree(tmp_path)
    document = (root / docs.TABLE_DOCUMENT).read_text(encoding='utf-8')
    before, marker, rest = document.partition(docs.TABLE_START)
    table_end = rest.index(docs.TABLE_END)
    stale_rows = rest[:table_end].replace('| `backlash` |', '| `backlash_old` |')
    (root / docs.TABLE_DOCUMENT).write_text(before + marker + stale_rows + rest[table_end:],
                                            encoding='utf-8')
    (root / 'config' / 'paper.yaml').write_text('# stale\n', encoding='utf-8')
    assert docs.main(['--write', '--root', str(root)]) == 0
    assert 'rewrote' in capsys.readouterr().out
    assert (root / docs.TABLE_DOCUMENT).read_text(encoding='utf-8') == document   # the rest too
    assert (root / 'config' / 'paper.yaml').read_text(encoding='utf-8') == docs.paper_yaml()
    assert docs.main(['--write', '--root', str(root)]) == 0
    assert 'current' in capsys.readouterr().out


def test_write_refuses_a_tree_without_the_documents(tmp_path, capsys):
    """A directory that is no source tree is named with the reason, nothing written."""
    (tmp_path / 'docs').mkdir()
    (tmp_path / docs.TABLE_DOCUMENT).write_text('no table here\n', encoding='utf-8')
    (tmp_path / 'config').mkdir()
    (tmp_path / 'config' / 'paper.yaml').write_text('x: 1\n', encoding='utf-8')
    for root, why in ((tmp_path / 'nothing', 'is not a file'),
                      (tmp_path, 'has no parameter table')):
        assert docs.main(['--write', '--root', str(root)]) == 2
        assert why in capsys.readouterr().err
    assert (tmp_path / 'config' / 'paper.yaml').read_text(encoding='utf-8') == 'x: 1\n'
