"""The installed ``paper_report`` command writes a report whose links and figures are real."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import matplotlib.image as mpimg
import pytest


@pytest.fixture(scope='module')
def quick_report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp('report')
    exe = shutil.which('paper_report')
    command = [exe] if exe else [sys.executable, '-m', 'screwgear_ros.cli.paper_report']
    done = subprocess.run(command + [str(out), '--quick'], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert 'wrote' in done.stdout
    return out


def test_every_link_is_a_relative_png_that_exists_and_every_figure_is_linked(
        quick_report: Path) -> None:
    text = (quick_report / 'report.md').read_text(encoding='utf-8')
    links = re.findall(r'!\[[^\]]*\]\(([^)]+)\)', text)
    assert len(links) >= 9
    for link in links:
        assert not Path(link).is_absolute() and '://' not in link
        image = mpimg.imread(quick_report / link)
        assert image.shape[0] > 300 and image.shape[1] > 600    # a real, readable figure
    assert set(links) == {p.name for p in quick_report.glob('*.png')}


def test_report_has_every_section_and_a_verdict_for_each_claim(quick_report: Path) -> None:
    text = (quick_report / 'report.md').read_text(encoding='utf-8')
    headings = re.findall(r'^## (\d+)\. ', text, flags=re.MULTILINE)
    assert headings == [str(n) for n in range(1, 13)]
    summary = text.split('## Summary of verdicts')[1].split('\n## ')[0]
    rows = [r for r in summary.splitlines() if r.startswith('| §')]
    assert len(rows) >= 20
    assert all(re.search(r'\*\*(holds|does not hold|vague|cannot be checked)', r)
               for r in rows)
    # Each table row has as many cells as its header (no stray '|' inside a cell).
    for block in re.findall(r'((?:^\|.*\|\n)+)', text, flags=re.MULTILINE):
        lines = block.strip().splitlines()
        cells = [len(re.split(r'(?<!\\)\|', line)) for line in lines]
        assert len(set(cells)) == 1, lines[0]
    # The performance-index arithmetic appears as computed, beside the paper's numbers.
    assert '3162.3 (10^7)' in text and '790.6 (10^7)' in text
