"""The installed ``paper_report`` command writes a report whose links and figures are real."""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import matplotlib.image as mpimg
import pytest
from paths import ROOT

from screwgear_ros.paper.builder import SECTIONS


@pytest.fixture(scope='module')
def quick_report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp('report')
    exe = shutil.which('paper_report')
    command = [exe] if exe else [sys.executable, '-m', 'screwgear_ros.cli.paper_report']
    done = subprocess.run(command + [str(out), '--quick'], capture_output=True, text=True,
                          timeout=300, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    assert 'wrote' in done.stdout
    return out


@pytest.mark.ros
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


@pytest.mark.ros
def test_report_has_every_section_and_a_verdict_for_each_claim(quick_report: Path) -> None:
    text = (quick_report / 'report.md').read_text(encoding='utf-8')
    headings = re.findall(r'^## (\d+)\. ', text, flags=re.MULTILINE)
    assert headings == [str(n) for n in range(1, len(SECTIONS) + 1)]
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


def _seed_text() -> str | None:
    """The paper's text (the project's seed) if it is on this machine."""
    root = ROOT
    for folder in (root.parent / 'shared' / 'seed', Path('/work/shared/seed')):
        files = sorted(folder.glob('*.txt')) if folder.is_dir() else []
        if files:
            return files[0].read_text(encoding='utf-8')
    return None


@pytest.mark.ros
def test_report_names_its_paper_in_the_papers_own_words(quick_report: Path) -> None:
    text = (quick_report / 'report.md').read_text(encoding='utf-8')
    head = text.split('## Summary in physical units')[0]
    quotes = re.findall(r'"([^"]{20,})"', head)
    assert len(quotes) >= 3       # its subject, what it investigates, its mechanism
    assert 'double screw gear anti-backlash transmission mechanism' in head
    assert 'preloaded nuts' in head
    seed = _seed_text()
    if seed is not None:          # each quotation is the paper's text, verbatim
        for quote in quotes:
            assert quote in seed, quote


@pytest.mark.ros
def test_summary_gives_the_example_in_physical_units(quick_report: Path) -> None:
    from screwgear_ros.params.table import TableParams

    text = (quick_report / 'report.md').read_text(encoding='utf-8')
    first = text.split('## Summary in physical units')[1].split('\n## ')[0]
    p = TableParams()
    i1, i2, r1, r2 = p.inertia_pinion_1, p.inertia_table, p.radius_pinion_1, p.radius_table
    m_e = i1 * i2 / (i1 * r2 ** 2 + i2 * r1 ** 2)
    hz = math.sqrt(p.mesh_stiffness_mean / m_e) / (2 * math.pi)
    gap = 2 * p.backlash / r2                                   # rad at the table
    assert f'{hz:.1f} Hz' in first
    assert f'{gap * 1e6:.0f} µrad = {gap * 180 * 3600 / math.pi:.1f}″' in first
    assert f'{gap * 6e-3 * p.teeth_table / 2 * 1e6:.0f} µm on the' in first
    assert f'{(r2 / r1):.3f}' in first and f'{p.preload_torque:.0f} N·m' in first
    assert re.search(r'\*\*minimum preload\*\*.*\*\*\d+ N·m\*\*', first)
    # One line per section, each with a verdict.
    lines = re.findall(r'^- §(\d+) .*\*\*(holds|does not hold|vague|cannot be checked)',
                       first, flags=re.MULTILINE)
    assert [int(n) for n, _ in lines] == list(range(1, len(SECTIONS) + 1))


@pytest.mark.ros
def test_no_number_is_formatted_into_nonsense(quick_report: Path) -> None:
    text = (quick_report / 'report.md').read_text(encoding='utf-8')
    assert not re.search(r'at most 0(?![.\d])', text)
    assert not re.search(r'\bnan\b|\binf\b', text)


@pytest.mark.ros
def test_a_report_it_cannot_write_exits_2_with_one_line(tmp_path: Path) -> None:
    """Like every tool, a failure is its documented exit code and one line naming the input,
    never a traceback."""
    blocked = tmp_path / 'a_file'
    blocked.write_text('not a directory\n')
    exe = shutil.which('paper_report')
    command = [exe] if exe else [sys.executable, '-m', 'screwgear_ros.cli.paper_report']
    done = subprocess.run(command + [str(blocked / 'report'), '--quick'], capture_output=True,
                          text=True, timeout=120, check=False)
    assert done.returncode == 2, done.stderr[-2000:]
    assert 'Traceback' not in done.stderr
    assert done.stderr.startswith(f'paper_report: cannot write {blocked / "report"}'), done.stderr
