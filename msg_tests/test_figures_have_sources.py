"""Every measured figure README.md and docs/*.md quote next to a results/ link is in the file
it links (scripts/check_figures.py states the rule), and the checker catches what it must."""
import pytest

from scripts import check_figures


@pytest.mark.parametrize('page', check_figures.default_pages(),
                         ids=lambda page: page.relative_to(check_figures.ROOT).as_posix())
def test_the_figures_of_the_docs_are_in_the_results_they_link(page):
    assert check_figures.violations(page) == []


@pytest.fixture
def tree(tmp_path, monkeypatch):
    """A small checkout: results/, README.md and docs/ under tmp_path."""
    (tmp_path / 'results' / 'node').mkdir(parents=True)
    (tmp_path / 'docs').mkdir()
    (tmp_path / 'results' / 'speed.md').write_text(
        '| spheres | step |\n|---|---|\n| 10 000 | 26.0 µs |\n| 3 | 1.4× |\n')
    (tmp_path / 'results' / 'node' / 'rate.csv').write_text('rate_hz,lost\n30,0.5\n')
    monkeypatch.setattr(check_figures, 'ROOT', tmp_path)
    monkeypatch.setattr(check_figures, 'RESULTS', tmp_path / 'results')
    return tmp_path


def test_matching_figures_pass_in_any_spelling(tree):
    (tree / 'README.md').write_text(
        'A step takes 26.0 µs at 10,000 spheres, 1.4× the seed '
        '([speed](results/speed.md)).\n'
        '| 1 000 spheres | 26.0 us | [results](results/speed.md) |\n'
        'The node keeps 30 Hz and loses 0.5 % (`results/node/`).\n'
        '```\n99 ms in a code block is no claim: results/speed.md\n```\n')
    (tree / 'docs' / 'performance.md').write_text(
        '# Performance\n\n10 000 spheres: 26.0 µs a step ([speed](../results/speed.md)).\n'
        'Numbers with no unit (12 runs) need no link.\n')
    assert check_figures.violations(tree / 'README.md') == []
    assert check_figures.violations(tree / 'docs' / 'performance.md') == []


def test_a_figure_missing_from_its_results_file_is_reported_with_its_line(tree):
    (tree / 'README.md').write_text(
        'Intro.\n\nA step takes 26 µs and 2.5× less,\nmeasured ([speed](results/speed.md)).\n')
    assert check_figures.violations(tree / 'README.md') == [  # the paragraph's first line
        "README.md:3: '26' is in none of results/speed.md",
        "README.md:3: '2.5' is in none of results/speed.md"]


def test_a_figure_with_no_link_is_reported_in_performance_and_figures_sections(tree):
    (tree / 'docs' / 'performance.md').write_text('# Performance\n\nA step: 26.0 µs.\n')
    (tree / 'README.md').write_text(
        '# pool_sim\n\nIt runs at 30 Hz.\n\n## Headline figures\n\n- 26.0 µs a step\n'
        '\n## Next\n\nAgain 26.0 µs, not in a figures section.\n')
    assert check_figures.violations(tree / 'docs' / 'performance.md') == [
        "docs/performance.md:3: '26.0' quoted with no results/ link"]
    assert check_figures.violations(tree / 'README.md') == [
        "README.md:7: '26.0' quoted with no results/ link"]


def test_a_link_to_a_missing_results_file_is_reported(tree):
    (tree / 'README.md').write_text('It takes 26.0 µs ([gone](results/gone.md)).\n')
    assert check_figures.violations(tree / 'README.md') == [
        'README.md:1: links results/gone.md, which does not exist',
        "README.md:1: '26.0' is in none of results/gone.md"]


def test_figures_are_numbers_with_a_unit_and_normalised():
    assert check_figures.figures('1 000 ms, 1,000 Hz, 1\u2009000 fps, 5 spheres, 3 x 4, '
                                 '10–20 µs, 2.1 ms/step, 12 MB/s, `30 Hz`, 1.4×') == [
        ('1 000', '1000'), ('1,000', '1000'), ('1\u2009000', '1000'), ('10', '10'),
        ('20', '20'), ('2.1', '2.1'), ('12', '12'), ('1.4', '1.4')]


def test_the_command_exits_1_on_a_violation(tree, capsys):
    (tree / 'docs' / 'performance.md').write_text('A step: 26.0 µs.\n')
    assert check_figures.main([str(tree / 'docs' / 'performance.md')]) == 1
    assert 'docs/performance.md:1:' in capsys.readouterr().out
