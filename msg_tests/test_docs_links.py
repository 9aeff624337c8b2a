"""Every relative link in README.md, CHANGELOG.md and docs/ leads to a file of the repository,
and every docs page is linked from the README."""
from pathlib import Path
import re

import pytest

REPO = Path(__file__).resolve().parents[1]
PAGES = [REPO / 'README.md', REPO / 'CHANGELOG.md', *sorted((REPO / 'docs').glob('*.md'))]
LINK = re.compile(r'\]\(([^)\s]+)\)')


@pytest.mark.parametrize('page', PAGES, ids=lambda page: page.name)
def test_relative_links_lead_to_files(page):
    broken = []
    for target in LINK.findall(page.read_text()):
        if re.match(r'[a-z]+:', target) or target.startswith('#'):
            continue
        if not (page.parent / target.split('#')[0]).exists():
            broken.append(target)
    assert not broken, broken


def test_every_docs_page_is_linked_from_the_readme():
    readme = (REPO / 'README.md').read_text()
    assert [page.name for page in (REPO / 'docs').glob('*.md')
            if f'docs/{page.name}' not in readme] == []


def test_the_readme_stays_short():
    assert len((REPO / 'README.md').read_text().splitlines()) <= 250
