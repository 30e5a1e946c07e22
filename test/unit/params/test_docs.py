"""``python -m screwgear_ros.params.docs --write`` rewrites config/paper.yaml and the
README's parameter table in place, and touches nothing else of either file."""

from __future__ import annotations

import shutil
from pathlib import Path

from paths import ROOT

from screwgear_ros.params import docs


def _tree(root: Path) -> Path:
    (root / 'config').mkdir(parents=True)
    shutil.copy(ROOT / 'README.md', root / 'README.md')
    shutil.copy(ROOT / 'config' / 'paper.yaml', root / 'config' / 'paper.yaml')
    return root


def test_write_rewrites_a_stale_table_and_file_in_place(tmp_path, capsys):
    root = _tree(tmp_path)
    readme = (root / 'README.md').read_text(encoding='utf-8')
    before, marker, rest = readme.partition(docs.README_START)
    table_end = rest.index(docs.README_END)
    stale_rows = rest[:table_end].replace('| `backlash` |', '| `backlash_old` |')
    (root / 'README.md').write_text(before + marker + stale_rows + rest[table_end:],
                                    encoding='utf-8')
    (root / 'config' / 'paper.yaml').write_text('# stale\n', encoding='utf-8')
    assert docs.main(['--write', '--root', str(root)]) == 0
    assert 'rewrote' in capsys.readouterr().out
    assert (root / 'README.md').read_text(encoding='utf-8') == readme   # the rest untouched
    assert (root / 'config' / 'paper.yaml').read_text(encoding='utf-8') == docs.paper_yaml()
    assert docs.main(['--write', '--root', str(root)]) == 0
    assert 'current' in capsys.readouterr().out


def test_write_refuses_a_tree_without_the_documents(tmp_path, capsys):
    """A directory that is no source tree is named with the reason, nothing written."""
    (tmp_path / 'README.md').write_text('no table here\n', encoding='utf-8')
    (tmp_path / 'config').mkdir()
    (tmp_path / 'config' / 'paper.yaml').write_text('x: 1\n', encoding='utf-8')
    for root, why in ((tmp_path / 'nothing', 'is not a file'),
                      (tmp_path, 'has no parameter table')):
        assert docs.main(['--write', '--root', str(root)]) == 2
        assert why in capsys.readouterr().err
    assert (tmp_path / 'config' / 'paper.yaml').read_text(encoding='utf-8') == 'x: 1\n'
